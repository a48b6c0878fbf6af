"""Diffusive terms D_i of the continuity equation, Drho/Dt += delta h c0 D_i (slot ``D``),
between fluid particles only. x_ji = x_j - x_i = -(dx, dy, dz), so
x_ji . grad_i W_ij = -r^2 (dW/dr)/r, positive: density diffuses towards the neighbours'."""
from numba.extending import register_jitable

from .interaction import add_diffusion


def make_molteni(ctx):
    """Molteni & Colagrossi (2009): D_i = 2 sum_j (rho_j - rho_i) x_ji . grad_i W_ij /
    (r^2 + eps h^2) V_j. ``P.eps_h2`` = eps h^2."""
    grad, two = ctx.grad, ctx.dtype(2)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        r2 = r * r
        s = two * (J.rho[j] - I.rho[i]) * (-r2 * grad(r, P)) / (r2 + P.eps_h2)
        return add_diffusion(acc, s * J.vol[j])

    return term


def make_fourtakas(ctx, eos_density):
    """Fourtakas et al. (2019): Molteni's term with the hydrostatic part of the density
    difference removed, (rho_j - rho_i) - rho^H_ji, where rho^H_ji is the density difference
    that the EOS gives to the hydrostatic pressure difference rho0 g . x_ji, so that a column
    at rest is not diffused. ``eos_density`` is the inverse EOS rho(p)."""
    grad, two, dim, zero = ctx.grad, ctx.dtype(2), ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        gz = P.gz * dz if dim == 3 else zero
        dp_h = -P.rho0 * (P.gx * dx + P.gy * dy + gz)  # rho0 g . x_ji
        rho_h = eos_density(P.p0 + dp_h, P) - P.rho0
        r2 = r * r
        s = two * ((J.rho[j] - I.rho[i]) - rho_h) * (-r2 * grad(r, P)) / (r2 + P.eps_h2)
        return add_diffusion(acc, s * J.vol[j])

    return term


DIFFUSIVE_TERMS = {"MolteniDiffusiveTerm": make_molteni, "FourtakasDiffusiveTerm": make_fourtakas}
