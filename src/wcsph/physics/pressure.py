"""Pressure terms. Classic model: the accumulator is the acceleration (ax, ay, az) and ``pr``
is p/rho^2 of each particle, stored by the density pass so that no pair divides. WCSPH-BI:
the accumulator of ``physics.interaction`` (force density slots)."""
from numba.extending import register_jitable

from .interaction import add_force


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


# ------------------------------------------------------------------ WCSPH-BI (force density)
def make_bi_pressure(ctx):
    """f_i -= <grad p>_i^{Omega,sym} = sum_j (p_i + p_j) grad_i W_ij V_j (WCSPH-BI spec;
    antisymmetric in i, j, so fluid pairs conserve linear and angular momentum)."""
    grad = ctx.grad

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        f = -(I.p[i] + J.p[j]) * grad(r, P) * J.vol[j]
        return add_force(acc, f * dx, f * dy, f * dz)

    return term


def make_bi_boundary_pressure(ctx, conservative):
    """f_i -= <grad p>_i^{dOmega}: symmetric form sum_b (p_i + p_b) n_b W_ib S_b (consistent
    schemes; p_b interpolated from the fluid), or conservative form 2 p_i sum_b n_b W_ib S_b
    (the wall mirrors the particle's own pressure). n_b points out of the fluid."""
    w, dim, zero = ctx.w, ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        pb = I.p[i] if conservative else J.p[j]
        f = -(I.p[i] + pb) * w(r, P) * J.elementSize[j]
        fz = f * J.n[2, j] if dim == 3 else zero
        return add_force(acc, f * J.n[0, j], f * J.n[1, j], fz)

    return term
