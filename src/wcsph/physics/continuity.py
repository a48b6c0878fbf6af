"""Velocity divergence of the continuity equation, Drho/Dt = -rho <div v>, in the bulk and on
boundary elements (WCSPH-BI spec, table of spatial discretizations). Slot ``div``."""
from numba.extending import register_jitable

from .interaction import add_div


def make_divergence(ctx):
    """<div v>_i^{Omega,asym} = sum_j (v_j - v_i) . grad_i W_ij V_j (V_j = m_j/rho_j)."""
    grad, dim, zero = ctx.grad, ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        dvz = (J.v[2, j] - I.v[2, i]) * dz if dim == 3 else zero
        s = ((J.v[0, j] - I.v[0, i]) * dx + (J.v[1, j] - I.v[1, i]) * dy + dvz) * grad(r, P)
        return add_div(acc, s * J.vol[j])

    return term


def make_boundary_divergence(ctx, conservative):
    """<div v>_i^{dOmega} = c sum_b (v_b - v_i) . n_b W_ib S_b: c = 1 (asymmetric form of the
    consistent schemes) or 2 (conservative form). n_b points out of the fluid."""
    w, dim, zero = ctx.w, ctx.dim, ctx.zero
    c = ctx.dtype(2 if conservative else 1)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        dvz = (J.v[2, j] - I.v[2, i]) * J.n[2, j] if dim == 3 else zero
        s = (J.v[0, j] - I.v[0, i]) * J.n[0, j] + (J.v[1, j] - I.v[1, i]) * J.n[1, j] + dvz
        return add_div(acc, c * s * w(r, P) * J.elementSize[j])

    return term
