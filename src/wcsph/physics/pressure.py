"""Pressure accelerations. The accumulator is the acceleration (ax, ay, az); ``pr`` is
p/rho^2 of each particle, stored by the density pass so that no pair divides."""
import numpy as np
from numba.extending import register_jitable


def make_symmetric_pressure(ctx):
    """a_i -= m_j (p_i/rho_i^2 + p_j/rho_j^2) grad W_ij: the momentum- and angular-momentum-
    conserving form of Monaghan (1992), used by Becker & Teschner (2007)."""

    kernel_grad = ctx.grad

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        f = -J.m[j] * (I.pr[i] + J.pr[j]) * kernel_grad(r, P)
        return (acc[0] + f * dx, acc[1] + f * dy, acc[2] + f * dz)

    return term


def make_akinci_pressure(ctx):
    """Boundary pressure force of Akinci et al. (2012) eq. 10 with pressure mirroring
    (p_k = p_i, rho_k = rho_i, Band et al. 2018): a_i -= Psi_k 2 p_i/rho_i^2 grad W_ik.
    The mirrored form makes a full-support wall act like the fluid it replaces, which holds a
    hydrostatic column at rest; Akinci's single term leaves half the wall force missing."""

    kernel_grad = ctx.grad

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        f = -J.psi[j] * (I.pr[i] + I.pr[i]) * kernel_grad(r, P)
        return (acc[0] + f * dx, acc[1] + f * dy, acc[2] + f * dz)

    return term
