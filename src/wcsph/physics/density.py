"""Density by kernel summation (Becker & Teschner 2007) with Akinci et al. (2012) walls."""
from numba.extending import register_jitable


def make_summation(ctx):
    """rho_i += m_j W_ij over fluid neighbours."""

    kernel_w = ctx.w

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        return acc + J.m[j] * kernel_w(r, P)

    return term


def make_akinci_density(ctx):
    """rho_i += Psi_k W_ik over boundary neighbours, Akinci et al. (2012) eq. 4."""

    kernel_w = ctx.w

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        return acc + J.psi[j] * kernel_w(r, P)

    return term


def make_akinci_volume(ctx):
    """Sum over boundary neighbours l of W_kl; Psi_k = rho0 / sum (Akinci et al. 2012 eq. 5)."""

    kernel_w = ctx.w

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        return acc + kernel_w(r, P)

    return term
