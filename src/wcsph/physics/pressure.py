"""Pressure gradient of the momentum equation. Slot ``pressure``.

* ``BISymmetric`` (WCSPH-BI spec): f_i -= sum_j (p_i + p_j) grad_i W_ij V_j, a force density
  (divided by rho_i and the Shepard factor);
* ``Monaghan1992`` (Monaghan 1992; Becker & Teschner 2007): a_i -= sum_j m_j (p_i/rho_i^2 +
  p_j/rho_j^2) grad_i W_ij, with ``pr`` = p/rho^2 stored per particle so no pair divides;
* ``Monaghan1992ArtificialViscosity``: the same with Monaghan's Pi_ij inside the sum (third
  spec), alpha and beta.

Each form has its wall part for both wall models: the boundary integral over elements
(symmetric form for consistent schemes, conservative form 2 p_i sum n W S otherwise), or the
mirrored pressure over boundary particles (p_k = p_i, Band et al. 2018). With the CSPM kernel
correction every form becomes the corrected form -sum_j (p_j -/+ p_i) L_i grad_i W_ij V_j
(``cspm_form``: the exact difference form or the renormalized symmetric one) over fluid
neighbours, completed over boundary elements by -sum_b (p_b -/+ p_i) L_i n_b W S_b and, in the
symmetric form, over boundary particles by the mirrored pressure (``physics.correction``).
"""
from numba.extending import register_jitable

from .registry import NONNEG, Choice, Param, add
from .interaction import Terms, add_accel, add_force


def make_bi_pressure(ctx, mirrored=False):
    """f_i -= <grad p>_i^{Omega,sym} = sum_j (p_i + p_j) grad_i W_ij V_j (WCSPH-BI spec;
    antisymmetric in i, j, so fluid pairs conserve linear and angular momentum). ``mirrored``:
    over boundary particles with p_k = p_i and V_k = Psi_k/rho0."""
    grad = ctx.grad

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        pj = I.p[i] if mirrored else J.p[j]
        f = -(I.p[i] + pj) * grad(r, P) * J.vol[j]
        return add_force(acc, f * dx, f * dy, f * dz)

    return term


def make_corrected_pressure(ctx, symmetric, mirrored=False):
    """CSPM (Chen et al. 1999): f_i -= sum_j (p_j - p_i) L_i grad_i W_ij V_j, exact for a linear
    pressure field (``symmetric`` False), or the renormalized symmetric form
    f_i -= sum_j (p_i + p_j) L_i grad_i W_ij V_j (``symmetric``), whose p_i sum_j grad W V_j part
    keeps the particles ordered as the uncorrected symmetric form does. ``mirrored``: over
    boundary particles with p_k = p_i."""
    grad, dim = ctx.grad, ctx.dim
    from .correction import corrected_gradient
    sign = ctx.dtype(1 if symmetric else -1)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        g = grad(r, P)
        gx, gy, gz = corrected_gradient(i, I, g * dx, g * dy, g * dz, dim)
        pj = I.p[i] if mirrored else J.p[j]
        f = -(pj + sign * I.p[i]) * J.vol[j]
        return add_force(acc, f * gx, f * gy, f * gz)

    return term


def make_corrected_boundary_pressure(ctx, symmetric, conservative):
    """CSPM over boundary elements: f_i -= sum_b (p_b -/+ p_i) L_i n_b W_ib S_b, the difference
    or the symmetric form (p_b = p_i for conservative walls, symmetric form only)."""
    w, dim, zero = ctx.w, ctx.dim, ctx.zero
    from .correction import corrected_gradient
    sign = ctx.dtype(1 if symmetric else -1)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        nz = J.n[2, j] if dim == 3 else zero
        gx, gy, gz = corrected_gradient(i, I, J.n[0, j], J.n[1, j], nz, dim)
        pb = I.p[i] if conservative else J.p[j]
        f = -(pb + sign * I.p[i]) * w(r, P) * J.elementSize[j]
        return add_force(acc, f * gx, f * gy, f * gz)

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


def make_symmetric_pressure(ctx):
    """a_i -= m_j (p_i/rho_i^2 + p_j/rho_j^2) grad W_ij: the momentum- and angular-momentum-
    conserving form of Monaghan (1992), used by Becker & Teschner (2007)."""

    kernel_grad = ctx.grad

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        f = -J.m[j] * (I.pr[i] + J.pr[j]) * kernel_grad(r, P)
        return add_accel(acc, f * dx, f * dy, f * dz)

    return term


def make_akinci_pressure(ctx, mirrored=True):
    """Boundary pressure force of Akinci et al. (2012) eq. 10 with pressure mirroring
    (p_k = p_i, rho_k = rho_i, Band et al. 2018): a_i -= Psi_k 2 p_i/rho_i^2 grad W_ik.
    The mirrored form makes a full-support wall act like the fluid it replaces, which holds a
    hydrostatic column at rest; Akinci's single term leaves half the wall force missing.
    Not ``mirrored``: a_i -= Psi_k (p_i/rho_i^2 + p_k/rho_k^2) grad W_ik with the wall
    particles' own pressure (``wall_pressure = "adami"``)."""

    kernel_grad = ctx.grad

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        prk = I.pr[i] if mirrored else J.pr[j]
        f = -J.psi[j] * (I.pr[i] + prk) * kernel_grad(r, P)
        return add_accel(acc, f * dx, f * dy, f * dz)

    return term


def make_monaghan_pi(ctx, wall=False, noslip=False):
    """a_i -= sum_j m_j Pi_ij grad_i W_ij with Monaghan's (1992) artificial viscosity, as the
    third spec writes it: Pi_ij = (-alpha c_ij mu_ij + beta mu_ij^2) / rho_ij for approaching
    pairs (v_ij . x_ij < 0), else 0; mu_ij = h v_ij . x_ij / (r^2 + eta^2), c_ij and rho_ij
    the means of the pair's sound speeds (the EOS's, stored per particle as ``c``: computed
    per pair, its power made the step 3.6 times slower) and densities. eta^2 = ``eps`` h^2.
    m_j = V_j rho_j, which is Psi_k over boundary particles (``wall``: rho = rho0, c = c0
    there; ``noslip``: their no-slip velocity, ``physics.viscosity``). ``P.av_alpha_h`` = alpha
    h, ``P.av_beta_h2`` = beta h^2. A min, not a branch, selects the approaching pairs (the
    loop stays vectorised)."""
    grad, dim, zero, half = ctx.grad, ctx.dim, ctx.zero, ctx.dtype(0.5)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        if noslip:  # compile-time choice: the walls' no-slip velocity (``v_ext``)
            vj = J.v_ext
        else:
            vj = J.v
        vz = (I.v[2, i] - vj[2, j]) * dz if dim == 3 else zero
        x = min((I.v[0, i] - vj[0, j]) * dx + (I.v[1, i] - vj[1, j]) * dy + vz, zero) / (r * r + P.eps_h2)
        rho_i, rho_j = I.rho[i], J.rho[j]
        c = half * (I.c[i] + (P.c0 if wall else J.c[j]))
        pi = (-P.av_alpha_h * c * x + P.av_beta_h2 * x * x) / (half * (rho_i + rho_j))
        f = -J.vol[j] * rho_j * pi * grad(r, P)
        return add_accel(acc, f * dx, f * dy, f * dz)

    return term


def _wall_part(ctx, q, particles_term):
    if q.corrected:
        symmetric = q.m["cspm_form"] == "symmetric"
        if q.boundary == "elements":  # the boundary integral completes the corrected gradient
            return [make_corrected_boundary_pressure(ctx, symmetric, q.conservative)]
        return [make_corrected_pressure(ctx, True, mirrored=q.m["wall_pressure"] == "mirror")] if symmetric else []
    if q.boundary == "elements":
        return [make_bi_boundary_pressure(ctx, q.conservative)]
    return [particles_term(ctx, q.m["wall_pressure"] == "mirror")]


def _bulk(ctx, q, term):
    return make_corrected_pressure(ctx, q.m["cspm_form"] == "symmetric") if q.corrected else term(ctx)


def _build_bi(ctx, q):
    return Terms([_bulk(ctx, q, make_bi_pressure)], _wall_part(ctx, q, lambda ctx, m: make_bi_pressure(ctx, mirrored=m)))


def _build_monaghan(ctx, q):
    return Terms([_bulk(ctx, q, make_symmetric_pressure)], _wall_part(ctx, q, make_akinci_pressure))


def _build_monaghan_av(ctx, q):
    t = _build_monaghan(ctx, q)
    t.fluid.append(make_monaghan_pi(ctx))
    if q.boundary == "particles":
        t.wall.append(make_monaghan_pi(ctx, wall=True, noslip=q.noslip))
    return t


add("pressure", Choice(
    "BISymmetric", "WCSPH-BI spec: <grad p>^{Omega,sym} and its boundary forms",
    "f_i -= sum_j (p_i + p_j) grad_i W_ij V_j", build=_build_bi, implies=frozenset({"wall_volume"})))
add("pressure", Choice(
    "Monaghan1992", "Monaghan (1992); Becker & Teschner (2007) eq. 6",
    "a_i -= sum_j m_j (p_i/rho_i^2 + p_j/rho_j^2) grad_i W_ij", build=_build_monaghan, implies=frozenset({"pr"})))


def _one_artificial_viscosity(m):
    """Pi_ij (its ``av_alpha``) and the viscous slot's artificial viscosity (its ``alpha``, the
    WCSPH-BI spec's) are two forms of one term (Monaghan 1992): a case takes one of them."""
    if m["ViscousTerm"] == "ArtificialViscosity":
        return ("pressure", "'Monaghan1992ArtificialViscosity' carries an artificial viscosity (av_alpha, av_beta) and "
                "model.ViscousTerm = 'ArtificialViscosity' is a second one (alpha): choose one of them")
    return None


add("pressure", Choice(
    "Monaghan1992ArtificialViscosity", "third spec: momentum equation with artificial viscosity (Monaghan 1992)",
    "a_i -= sum_j m_j (p_i/rho_i^2 + p_j/rho_j^2 + Pi_ij) grad_i W_ij, Pi_ij with alpha and beta",
    params=(Param("av_alpha", 0.01, "alpha of Pi_ij (linear, bulk viscosity)", check=NONNEG),
            Param("av_beta", 0.0, "beta of Pi_ij (quadratic, against interpenetration at high Mach)",
                  check=NONNEG)),
    p_fields=("av_alpha_h", "av_beta_h2"),
    values=lambda q: {"av_alpha_h": q.m["av_alpha"] * q.h, "av_beta_h2": q.m["av_beta"] * q.h * q.h},
    build=_build_monaghan_av, implies=frozenset({"pr", "sound", "wall_volume"}), check=_one_artificial_viscosity))
