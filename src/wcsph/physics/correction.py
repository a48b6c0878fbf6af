"""Kernel correction: the Corrected Smoothed Particle Method (CSPM) of Chen, Beraun & Carney
(1999), with the gradient correction in the matrix form of Bonet & Lok (1999) / Randles &
Libersky (1996). Slot ``kernel_correction``.

* **Gradient correction.** Once per derivative evaluation a pass builds, for each fluid
  particle, M_i = sum_j V_j grad_i W_ij (x) x_ji over its fluid neighbours (symmetric, about
  the identity in the bulk) and stores L_i = M_i^-1; the pressure gradient and the velocity
  divergence then use L_i grad_i W_ij in their difference forms, sum_j (f_j - f_i) L_i
  grad_i W_ij V_j, which is exact for a linear field f wherever M_i is invertible, next to a
  free surface or a wall included. Where M_i is near singular ((det M_i)^(1/d) <
  ``cspm_threshold``, the geometric mean of its eigenvalues: a splash particle with few
  neighbours in a line) L_i = I, the uncorrected gradient.
* **Density re-initialisation.** Every ``cspm_density_interval`` steps the continuity
  density is replaced by its corrective (Shepard) interpolation rho_i = sum_j m_j W_ij /
  sum_j V_j W_ij (Chen et al. 1999 eq. 14; Colagrossi & Landrini 2003), boundary particles
  counted with m = Psi and V = Psi/rho0.

**Two forms of grad p** (``cspm_form``). ``difference``: -sum_j (p_j - p_i) L_i grad W V_j,
exact for linear fields but with no force at all for a uniform pressure, so nothing keeps a
disordered particle set in order: measured, it blows up a WCSPH-BI hydrostatic tank within
0.012 s (a free-surface particle by the wall first). ``symmetric`` (the default): the
renormalized symmetric form -sum_j (p_i + p_j) L_i grad W V_j, exact where the kernel sum is
complete (sum_j grad W V_j + walls = 0) and as robust as the uncorrected form. The velocity
divergence always takes the exact difference form.

**Walls.** Over boundary elements the boundary integral completes M_i, M_i += sum_b S_b W_ib
n_b (x) x_bi, and the sums: grad p gets sum_b (p_b -/+ p_i) L_i n_b W_ib S_b (p_b = p_i for
conservative walls; the difference form needs the consistent walls' interpolated p_b), div v
sum_b (v_b - v_i) . L_i n_b W_ib S_b; the Shepard factor no longer divides them (M_i is
gamma_i I in the continuum, so the corrected sums are the derivatives themselves). Over
boundary particles (Akinci) the symmetric form counts them in M_i and in both sums (mirrored
pressure); the difference form counts the fluid only and leaves the wall pressure out.

L_i is stored row by row, dim x dim entries, in the field ``L``.
"""
from numba.extending import register_jitable

from .registry import NONNEG, POS, Choice, Param, add, one_of
from . import AfterStepPass, FluidPass


@register_jitable
def corrected_gradient(i, I, gx, gy, gz, dim):
    """L_i (gx, gy, gz)."""
    if dim == 3:
        return (I.L[0, i] * gx + I.L[1, i] * gy + I.L[2, i] * gz,
                I.L[3, i] * gx + I.L[4, i] * gy + I.L[5, i] * gz,
                I.L[6, i] * gx + I.L[7, i] * gy + I.L[8, i] * gz)
    return (I.L[0, i] * gx + I.L[1, i] * gy, I.L[2, i] * gx + I.L[3, i] * gy, gz)


def make_cspm_matrix(ctx):
    """Pair term of M_i = sum_j V_j grad_i W_ij (x) x_ji: with grad_i W_ij = g (x_i - x_j) and
    x_ji = -(x_i - x_j), M_ab += -g V_j d_a d_b. Accumulator: M row by row (3 x 3)."""
    grad = ctx.grad

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        s = -grad(r, P) * J.vol[j]
        xy, xz, yz = s * dx * dy, s * dx * dz, s * dy * dz
        return (acc[0] + s * dx * dx, acc[1] + xy, acc[2] + xz, acc[3] + xy, acc[4] + s * dy * dy, acc[5] + yz,
                acc[6] + xz, acc[7] + yz, acc[8] + s * dz * dz)

    return term


def make_cspm_boundary(ctx):
    """Boundary-element part of M_i: S_b W_ib n_b (x) x_bi, x_bi = -(dx, dy, dz)."""
    w, dim, zero = ctx.w, ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        s = -w(r, P) * J.elementSize[j]
        nx, ny = J.n[0, j] * s, J.n[1, j] * s
        nz = J.n[2, j] * s if dim == 3 else zero
        return (acc[0] + nx * dx, acc[1] + nx * dy, acc[2] + nx * dz, acc[3] + ny * dx, acc[4] + ny * dy,
                acc[5] + ny * dz, acc[6] + nz * dx, acc[7] + nz * dy, acc[8] + nz * dz)

    return term


def make_cspm_store(ctx):
    """L_i = M_i^-1, or I where det M_i < ``P.cspm_min_det`` = threshold^d."""
    dim, zero, one = ctx.dim, ctx.zero, ctx.dtype(1)

    @register_jitable
    def init(i, I, P):
        return (zero, zero, zero, zero, zero, zero, zero, zero, zero)

    @register_jitable
    def store(i, I, P, acc):
        a, b, c, d, e, f, g, h, k = acc  # rows (a b c), (d e f), (g h k)
        if dim == 2:
            det = a * e - b * d
            if det < P.cspm_min_det:
                a, b, d, e, det = one, zero, zero, one, one
            q = one / det
            I.L[0, i] = e * q
            I.L[1, i] = -b * q
            I.L[2, i] = -d * q
            I.L[3, i] = a * q
        else:
            c00, c01, c02 = e * k - f * h, c * h - b * k, b * f - c * e
            c10, c11, c12 = f * g - d * k, a * k - c * g, c * d - a * f
            c20, c21, c22 = d * h - e * g, b * g - a * h, a * e - b * d
            det = a * c00 + b * c10 + c * c20
            if det < P.cspm_min_det:
                c00, c01, c02, c10, c11, c12, c20, c21, c22, det = one, zero, zero, zero, one, zero, zero, zero, one, one
            q = one / det
            I.L[0, i] = c00 * q
            I.L[1, i] = c01 * q
            I.L[2, i] = c02 * q
            I.L[3, i] = c10 * q
            I.L[4, i] = c11 * q
            I.L[5, i] = c12 * q
            I.L[6, i] = c20 * q
            I.L[7, i] = c21 * q
            I.L[8, i] = c22 * q

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


def _check(m):
    if m["cspm_form"] == "difference" and m["BCType"] == "BIConservative_numeric":
        return ("cspm_form", "'difference' over boundary elements needs model.BCType = 'BIConsistent_numeric' "
                "(its wall pressure p_b completes the corrected gradient), not 'BIConservative_numeric'")
    return None


def make_apply_density(ctx):
    @register_jitable
    def apply(i, I, P):
        I.rho[i] = I.rho_corr[i]

    return apply


def _passes(ctx, q):
    """Before each interaction the matrix L_i (over fluid neighbours, and over the walls:
    boundary elements, or boundary particles in the symmetric form); after every
    ``cspm_density_interval`` steps (continuity density) the Shepard density re-initialisation."""
    init, store = make_cspm_store(ctx)
    if q.boundary == "elements":
        wall = make_cspm_boundary(ctx)
    else:  # boundary particles count in the symmetric form only
        wall = make_cspm_matrix(ctx) if q.m["cspm_form"] == "symmetric" else None
    out = [FluidPass(init, make_cspm_matrix(ctx), store, wall=wall)]
    if q.continuity and q.m["cspm_density_interval"] > 0:
        init_d, store_d = make_shepard_density_store(ctx)
        term = make_shepard_density(ctx)
        out.append(AfterStepPass(init_d, term, store_d, make_apply_density(ctx),
                                 wall=term if q.boundary == "particles" else None, every=q.m["cspm_density_interval"]))
    return out


add("correction", Choice("None", "-", "plain kernel gradient"))
add("correction", Choice(
    "CSPM", "Chen, Beraun & Carney (1999); matrix form: Bonet & Lok (1999)",
    "L_i = (sum_j V_j grad W_ij (x) x_ji)^-1 on the pressure gradient and velocity divergence "
    "(difference forms); Shepard density re-initialisation every cspm_density_interval steps",
    params=(Param("cspm_density_interval", 20, "steps between density re-initialisations (0: never; "
                  "continuity density only)", kind="int", check=NONNEG),
            Param("cspm_form", "symmetric", "grad p: 'symmetric' (renormalized, robust) or 'difference' "
                  "(exact for linear fields)", kind="str", check=one_of("symmetric", "difference")),
            Param("cspm_threshold", 0.1, "(det M_i)^(1/d) below which L_i = I (near-singular M_i; "
                  "M_i = I in the bulk)", check=POS)),
    p_fields=("cspm_min_det",), values=lambda q: {"cspm_min_det": q.m["cspm_threshold"] ** q.dim}, check=_check,
    implies=frozenset({"corrected", "wall_volume"}), passes=_passes))
