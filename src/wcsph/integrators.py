"""Time integrators, independent of the model. They see a particle set's state through
``StateView`` (x, v and, for models with a continuity equation, rho) and its derivatives
(dvdt, drhodt), and call back ``sim.evaluate()`` for the derivatives at the current state.
A model without a continuity equation (density by summation) has ``continuity = False``;
the integrator then leaves rho alone.
"""
from collections import namedtuple

from numba.extending import register_jitable

StateView = namedtuple("StateView", "x v dvdt rho drhodt x_old v_old rho_old")


def make_symplectic_euler(dim, continuity, dtype):
    """Semi-implicit (symplectic) Euler of Becker & Teschner (2007):
    v(t+dt) = v(t) + dt a(t);  x(t+dt) = x(t) + dt v(t+dt);  rho += dt Drho/Dt."""

    @register_jitable
    def advance(i, I, P):
        for d in range(dim):
            I.v[d, i] += P.dt * I.dvdt[d, i]
            I.x[d, i] += P.dt * I.v[d, i]
        if continuity:
            I.rho[i] += P.dt * I.drhodt[i]

    return (advance,)


def make_symplectic_verlet(dim, continuity, dtype):
    """Symplectic position Verlet, predictor-corrector (Leimkuhler, Reich & Skeel 1996;
    the DualSPHysics "Symplectic" scheme), as the spec writes it with two slips corrected:
    predictor  x' = x_n + dt/2 v_n, v' = v_n + dt/2 a_n, rho' = rho_n + dt/2 Drho_n;
    corrector  v_n+1 = v_n + dt a', x_n+1 = x_n + dt (v_n + v_n+1)/2,
               rho_n+1 = rho_n (2 - e)/(2 + e), e = -Drho'/rho' dt (Monaghan 2005: exact for
               a uniform compression, keeps rho > 0)."""
    half, two = dtype(0.5), dtype(2)

    @register_jitable
    def predict(i, I, P):
        h = P.dt * half
        for d in range(dim):
            I.x_old[d, i] = I.x[d, i]
            I.v_old[d, i] = I.v[d, i]
            I.x[d, i] += h * I.v[d, i]
            I.v[d, i] += h * I.dvdt[d, i]
        if continuity:
            I.rho_old[i] = I.rho[i]
            I.rho[i] += h * I.drhodt[i]

    @register_jitable
    def correct(i, I, P):
        h = P.dt * half
        for d in range(dim):
            v1 = I.v_old[d, i] + P.dt * I.dvdt[d, i]
            I.x[d, i] = I.x_old[d, i] + h * (I.v_old[d, i] + v1)
            I.v[d, i] = v1
        if continuity:
            e = -I.drhodt[i] / I.rho[i] * P.dt
            I.rho[i] = I.rho_old[i] * (two - e) / (two + e)

    return predict, correct


class Integrator:
    """A scheme as a sequence of derivative evaluations and per-particle maps."""

    fields = ()  # per-particle arrays the scheme keeps within a step: (name, kind, scratch)

    def __init__(self, backend, dim, continuity, dtype):
        self.maps = [backend.make_map(f) for f in self.factory(dim, continuity, dtype)]


class SymplecticEuler(Integrator):
    factory = staticmethod(make_symplectic_euler)

    def step(self, sim, P):
        sim.evaluate(P)
        self.maps[0](sim.state(), P)


class SymplecticVerlet(Integrator):
    factory = staticmethod(make_symplectic_verlet)
    fields = (("x_old", "vector", True), ("v_old", "vector", True), ("rho_old", "scalar", True))

    def step(self, sim, P):
        predict, correct = self.maps
        sim.evaluate(P)
        predict(sim.state(), P)
        sim.evaluate(P)
        correct(sim.state(), P)


INTEGRATORS = {"symplectic_euler": SymplecticEuler, "symplectic_verlet": SymplecticVerlet}
