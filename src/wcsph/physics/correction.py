"""Kernel correction: the Corrected Smoothed Particle Method (CSPM) of Chen, Beraun & Carney
(1999), with the gradient correction in the matrix form of Bonet & Lok (1999) / Randles &
Libersky (1996). Slot ``kernel_correction``.

* **Gradient correction.** Once per derivative evaluation a pass builds, for each fluid
  particle, M_i = sum_j V_j grad_i W_ij (x) x_ji over its fluid neighbours (symmetric, about
  the identity in the bulk) and stores L_i = M_i^-1; the pressure gradient and the velocity
  divergence then use L_i grad_i W_ij in their difference forms, sum_j (f_j - f_i) L_i
  grad_i W_ij V_j, which is exact for a linear field f wherever M_i is invertible, next to a
  free surface or a wall included. Where M_i is near singular (det M_i < ``cspm_min_det``: a
  splash particle with few neighbours in a line) L_i = I, the uncorrected gradient.
* **Density re-initialisation.** Every ``cspm_density_interval`` steps the continuity
  density is replaced by its corrective (Shepard) interpolation rho_i = sum_j m_j W_ij /
  sum_j V_j W_ij (Chen et al. 1999 eq. 14; Colagrossi & Landrini 2003), boundary particles
  counted with m = Psi and V = Psi/rho0.

L_i is stored as its 6 distinct entries (xx, xy, yy, xz, yz, zz; 3 in 2D) in the field ``L``.
"""
from numba.extending import register_jitable

from ..registry import NONNEG, POS, Choice, Param, add


@register_jitable
def corrected_gradient(i, I, gx, gy, gz, dim):
    """L_i (gx, gy, gz)."""
    if dim == 3:
        return (I.L[0, i] * gx + I.L[1, i] * gy + I.L[3, i] * gz,
                I.L[1, i] * gx + I.L[2, i] * gy + I.L[4, i] * gz,
                I.L[3, i] * gx + I.L[4, i] * gy + I.L[5, i] * gz)
    return (I.L[0, i] * gx + I.L[1, i] * gy, I.L[1, i] * gx + I.L[2, i] * gy, gz)


def make_cspm_matrix(ctx):
    """Pair term of M_i = sum_j V_j grad_i W_ij (x) x_ji: with grad_i W_ij = g (x_i - x_j) and
    x_ji = -(x_i - x_j), M_ab += -g V_j d_a d_b. Accumulator (xx, xy, yy, xz, yz, zz)."""
    grad = ctx.grad

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        s = -grad(r, P) * J.vol[j]
        return (acc[0] + s * dx * dx, acc[1] + s * dx * dy, acc[2] + s * dy * dy,
                acc[3] + s * dx * dz, acc[4] + s * dy * dz, acc[5] + s * dz * dz)

    return term


def make_cspm_store(ctx):
    """L_i = M_i^-1 (symmetric), or I where det M_i < ``P.cspm_min_det``."""
    dim, zero, one = ctx.dim, ctx.zero, ctx.dtype(1)

    @register_jitable
    def init(i, I, P):
        return (zero, zero, zero, zero, zero, zero)

    @register_jitable
    def store(i, I, P, acc):
        a, b, c, d, e, f = acc  # xx xy yy xz yz zz
        if dim == 2:
            det = a * c - b * b
            if det < P.cspm_min_det:
                a, b, c, det = one, zero, one, one
            k = one / det
            I.L[0, i] = c * k
            I.L[1, i] = -b * k
            I.L[2, i] = a * k
        else:
            c00 = c * f - e * e
            c01 = d * e - b * f
            c02 = b * e - c * d
            det = a * c00 + b * c01 + d * c02
            if det < P.cspm_min_det:
                I.L[0, i] = one
                I.L[1, i] = zero
                I.L[2, i] = one
                I.L[3, i] = zero
                I.L[4, i] = zero
                I.L[5, i] = one
                return
            k = one / det
            I.L[0, i] = c00 * k
            I.L[1, i] = c01 * k
            I.L[2, i] = (a * f - d * d) * k
            I.L[3, i] = c02 * k
            I.L[4, i] = (b * d - a * e) * k
            I.L[5, i] = (a * c - b * b) * k

    return init, store


def make_shepard_density(ctx):
    """Pair term of the density re-initialisation: (sum m_j W, sum V_j W), with m_j = V_j rho_j
    (fluid) or Psi_k (boundary particles, V = Psi/rho0, rho = rho0)."""
    w = ctx.w

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        wv = w(r, P) * J.vol[j]
        return (acc[0] + wv * J.rho[j], acc[1] + wv)

    return term


def make_shepard_density_store(ctx):
    zero = ctx.zero

    @register_jitable
    def init(i, I, P):
        return (zero, zero)

    @register_jitable
    def store(i, I, P, acc):
        I.rho_corr[i] = acc[0] / acc[1] if acc[1] > zero else I.rho[i]

    return init, store


add("correction", Choice("None", "-", "plain kernel gradient"))
add("correction", Choice(
    "CSPM", "Chen, Beraun & Carney (1999); matrix form: Bonet & Lok (1999)",
    "L_i = (sum_j V_j grad W_ij (x) x_ji)^-1 on the pressure gradient and velocity divergence "
    "(difference forms); Shepard density re-initialisation every cspm_density_interval steps",
    params=(Param("cspm_density_interval", 20, "steps between density re-initialisations (0: never; "
                  "continuity density only)", kind="int", check=NONNEG),
            Param("cspm_min_det", 0.05, "det M_i below which L_i = I (near-singular M_i)", check=POS)),
    p_fields=("cspm_min_det",), values=lambda q: {"cspm_min_det": q.m["cspm_min_det"]}))
