"""Diffusive terms D_i of the continuity equation, Drho/Dt += delta h c0 D_i (slot ``D`` of the
accumulator), between fluid particles only. Slot ``DiffusiveTerm``; continuity density only.
x_ji = x_j - x_i = -(dx, dy, dz), so x_ji . grad_i W_ij = -r^2 (dW/dr)/r, positive: density
diffuses towards the neighbours'."""
from numba.extending import register_jitable

from .registry import NONNEG, Choice, Param, add
from .interaction import Terms, add_diffusion

DELTA = Param("delta", 0.1, "delta of the diffusive term delta h c0 D_i", check=NONNEG, spec=True)


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
    at rest is not diffused (the third spec's rho^H_ij with P^H_ij = rho0 g z_ij, through the
    inverse of whichever EOS the case uses, ``eos_density``)."""
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


def _delta(q):
    return {"delta_hc0": q.m["delta"] * q.h * q.c0}


add("diffusive", Choice("None", "-", "no density diffusion"))
add("diffusive", Choice(
    "MolteniDiffusiveTerm", "Molteni & Colagrossi (2009); WCSPH-BI spec",
    "D_i = 2 sum_j (rho_j - rho_i) x_ji . grad W_ij / (r^2 + eps h^2) V_j", params=(DELTA,),
    p_fields=("delta_hc0",), values=_delta, requires={"density": ("continuity",)},
    build=lambda ctx, q: Terms([make_molteni(ctx)])))
add("diffusive", Choice(
    "FourtakasDiffusiveTerm", "Fourtakas et al. (2019); third spec's density diffusion with hydrostatic correction",
    "Molteni's term with (rho_j - rho_i) - rho^H_ji", params=(DELTA,), p_fields=("delta_hc0",), values=_delta,
    requires={"density": ("continuity",)}, build=lambda ctx, q: Terms([make_fourtakas(ctx, q.eos_density)])))
