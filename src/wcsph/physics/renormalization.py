"""Shepard renormalization of the consistent WCSPH-BI schemes, and the boundary pressure they
interpolate from the fluid."""
from numba.extending import register_jitable

from .interaction import add_gamma


def make_shepard(ctx):
    """gamma_i = sum_j W_ij V_j over fluid particles (the self pair included): 1 in the bulk,
    less near walls and the free surface."""
    w = ctx.w

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        return add_gamma(acc, w(r, P) * J.vol[j])

    return term


def make_boundary_interpolation(ctx):
    """Boundary element b, fluid neighbour j: accumulate (sum_j (p_j + rho_j g . x_bj) W V_j,
    sum_j rho_j W V_j, sum_j W V_j). Divided by the last (Shepard), these give the wall
    pressure with the hydrostatic correction of Adami, Hu & Adams (2012) and the wall density;
    (dx, dy, dz) = x_b - x_j."""
    w, dim, zero = ctx.w, ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        wv = w(r, P) * J.vol[j]
        gz = P.gz * dz if dim == 3 else zero
        p = J.p[j] + J.rho[j] * (P.gx * dx + P.gy * dy + gz)
        return (acc[0] + p * wv, acc[1] + J.rho[j] * wv, acc[2] + wv)

    return term
