"""Time integrators, independent of the model: they see a set's x, v and a."""
from numba.extending import register_jitable


def make_symplectic_euler(dim):
    """Semi-implicit (symplectic) Euler of Becker & Teschner (2007):
    v(t+dt) = v(t) + dt a(t);  x(t+dt) = x(t) + dt v(t+dt)."""

    @register_jitable
    def advance(i, I, P):
        for d in range(dim):
            I.v[d, i] += P.dt * I.a[d, i]
            I.x[d, i] += P.dt * I.v[d, i]

    return advance


INTEGRATORS = {"symplectic_euler": make_symplectic_euler}
