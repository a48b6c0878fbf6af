"""Density: by kernel summation (Becker & Teschner 2007) with Akinci et al. (2012) walls, or
by the continuity equation Drho/Dt = -rho <div v> (the WCSPH-BI spec's table of spatial
discretizations). Slot ``density``."""
from numba.extending import register_jitable

from .registry import Choice, add
from . import WallVolume
from .interaction import Terms, add_div


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
    """The boundary particles' pseudo-mass Psi_k = rho0 / sum_l W_kl over wall neighbours l
    (Akinci et al. 2012 eq. 5), as a ``WallVolume``."""
    kernel_w, zero = ctx.w, ctx.zero

    @register_jitable
    def init(i, I, P):
        return zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        return acc + kernel_w(r, P)

    @register_jitable
    def store(i, I, P, acc):
        I.psi[i] = P.rho0 / acc

    return WallVolume(init, term, store)


def make_divergence(ctx, corrected=False):
    """<div v>_i^{Omega,asym} = sum_j (v_j - v_i) . grad_i W_ij V_j (V_j = m_j/rho_j), over
    fluid neighbours and over boundary particles (V_k = Psi_k/rho0, velocity v_k).
    ``corrected``: with the CSPM gradient L_i grad_i W_ij (Chen, Beraun & Carney 1999)."""
    grad, dim, zero = ctx.grad, ctx.dim, ctx.zero
    from .correction import corrected_gradient

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        if corrected:  # a compile-time choice
            g = grad(r, P)
            gx, gy, gz = corrected_gradient(i, I, g * dx, g * dy, g * dz, dim)
            dvz = (J.v[2, j] - I.v[2, i]) * gz if dim == 3 else zero
            s = (J.v[0, j] - I.v[0, i]) * gx + (J.v[1, j] - I.v[1, i]) * gy + dvz
        else:  # the gradient factored out: one multiplication by it, not three
            dvz = (J.v[2, j] - I.v[2, i]) * dz if dim == 3 else zero
            s = ((J.v[0, j] - I.v[0, i]) * dx + (J.v[1, j] - I.v[1, i]) * dy + dvz) * grad(r, P)
        return add_div(acc, s * J.vol[j])

    return term


def make_boundary_divergence(ctx, conservative, corrected=False):
    """<div v>_i^{dOmega} = c sum_b (v_b - v_i) . n_b W_ib S_b: c = 1 (asymmetric form of the
    consistent schemes) or 2 (conservative form). n_b points out of the fluid. ``corrected``
    (CSPM, consistent walls): with L_i n_b in place of n_b."""
    w, dim, zero = ctx.w, ctx.dim, ctx.zero
    c = ctx.dtype(2 if conservative else 1)
    from .correction import corrected_gradient

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        nx, ny = J.n[0, j], J.n[1, j]
        nz = J.n[2, j] if dim == 3 else zero
        if corrected:
            nx, ny, nz = corrected_gradient(i, I, nx, ny, nz, dim)
        dvz = (J.v[2, j] - I.v[2, i]) * nz if dim == 3 else zero
        s = (J.v[0, j] - I.v[0, i]) * nx + (J.v[1, j] - I.v[1, i]) * ny + dvz
        return add_div(acc, c * s * w(r, P) * J.elementSize[j])

    return term


def _continuity(ctx, q):
    if q.boundary == "elements":
        wall = make_boundary_divergence(ctx, q.conservative, q.corrected)
    else:  # boundary particles: the bulk sum continued over them (corrected where L_i counts them)
        wall = make_divergence(ctx, q.corrected and q.m["cspm_form"] == "symmetric")
    return Terms([make_divergence(ctx, q.corrected)], [wall])


add("density", Choice(
    "summation", "Becker & Teschner (2007) eq. 4; Akinci et al. (2012) eq. 4",
    "rho_i = sum_j m_j W_ij + sum_k Psi_k W_ik, every evaluation", walls=("particles",),
    build=lambda ctx, q: (make_summation(ctx), make_akinci_density(ctx))))
add("density", Choice(
    "continuity", "WCSPH-BI spec, table of spatial discretizations",
    "Drho/Dt = -rho <div v> (+ the diffusive term), rho advanced by the integrator", build=_continuity,
    implies=frozenset({"continuity", "wall_volume"})))
