"""Viscous terms. The accumulator is the acceleration (ax, ay, az)."""
import numpy as np
from numba.extending import register_jitable


def make_xsph(ctx):
    """XSPH velocity smoothing of Monaghan (1989) as in Becker & Teschner (2007):
    v_i <- v_i + alpha sum_j m_j/rho_j (v_j - v_i) W_ij, applied as the acceleration
    alpha/dt sum_j ... so that one symplectic Euler step reproduces the smoothing exactly
    (the way SPlisHSPlasH applies it). ``P.xsph_dt`` = alpha/dt, ``vol`` = m/rho."""

    kernel_w, dim, zero = ctx.w, ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        f = P.xsph_dt * J.vol[j] * kernel_w(r, P)
        fz = f * (J.v[2, j] - I.v[2, i]) if dim == 3 else zero
        return (acc[0] + f * (J.v[0, j] - I.v[0, i]), acc[1] + f * (J.v[1, j] - I.v[1, i]),
                acc[2] + fz)

    return term


def make_xsph_wall(ctx):
    """XSPH towards the wall velocity over boundary particles with volume Psi_k/rho0
    (SPlisHSPlasH's boundary viscosity for Akinci walls). ``P.wall_xsph_dt`` = alpha_b/dt."""

    kernel_w, dim, zero = ctx.w, ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        f = P.wall_xsph_dt * J.psi[j] * P.rho0_inv * kernel_w(r, P)
        fz = f * (J.v[2, j] - I.v[2, i]) if dim == 3 else zero
        return (acc[0] + f * (J.v[0, j] - I.v[0, i]), acc[1] + f * (J.v[1, j] - I.v[1, i]),
                acc[2] + fz)

    return term
