"""Viscous terms of the momentum equation, slot ``ViscousTerm``. Each adds rho_i times its
acceleration to the force slot of the accumulator; the coefficient comes in ``P.visc`` (bulk)
and ``P.wall_visc`` (walls, times ``scaleBVTCoef``):
  MGVT: 2 (n + 2) mu,  MVT: 2 mu,  artificial: alpha h c0.
psi_ij = v_ij . x_ij / (r^2 + eps h^2) is shared by the bulk terms.

Over boundary elements the wall term is the spec's boundary integral; over boundary particles
(Akinci walls) the bulk term itself, with the particles' volume Psi/rho0, density rho0 and
velocity: the no-slip wall of Morris, Fox & Zhu (1997) and Adami, Hu & Adams (2012). Where the
walls make the no-slip velocity ``v_ext`` (``wall_velocity = "adami"``; ``q.noslip``, the
terms' ``noslip``) the viscous terms read it and nothing else does: the continuity equation,
XSPH, shifting and the collision read the wall's own velocity, so a no-slip wall does not
compress the water it shears (DualSPHysics' no-slip mDBC and TrixiParticles.jl do the same).
"""
import math

from numba.extending import register_jitable

from . import FluidPass
from .registry import NONNEG, POS, Choice, Param, add, one_of
from .interaction import Terms, add_force


def make_artificial_viscosity(ctx, wall=False, noslip=False):
    """Monaghan (1992) artificial viscosity, active between approaching particles:
    Dv_i/Dt += alpha h c0 sum_j m_j psi_ij / rho_bar_ij grad_i W_ij, rho_bar the mean density."""
    grad, dim, zero, two = ctx.grad, ctx.dim, ctx.zero, ctx.dtype(2)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        if noslip:  # compile-time choice: the walls' no-slip velocity (``v_ext``)
            vj = J.v_ext
        else:
            vj = J.v
        vz = (I.v[2, i] - vj[2, j]) * dz if dim == 3 else zero
        # only approaching pairs (v_ij . x_ij < 0); a min, not a branch, keeps the loop
        # vectorised (an early return made the whole pass 3.8 times slower)
        vx = min((I.v[0, i] - vj[0, j]) * dx + (I.v[1, i] - vj[1, j]) * dy + vz, zero)
        rho_i, rho_j = I.rho[i], J.rho[j]
        # one division per pair, not two
        f = (P.wall_visc if wall else P.visc) * two * rho_i * rho_j * vx / ((rho_i + rho_j) * (r * r + P.eps_h2)) * grad(r, P) * J.vol[j]
        return add_force(acc, f * dx, f * dy, f * dz)

    return term


def make_mgvt(ctx, wall=False, noslip=False):
    """Monaghan & Gingold (1983) form of mu <Lap v + 2 grad div v>:
    2 (n + 2) mu sum_j psi_ij grad_i W_ij V_j (Monaghan 2005, sec. 6.2); the force is along
    x_ij, so fluid pairs conserve angular momentum."""
    grad, dim, zero = ctx.grad, ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        if noslip:  # compile-time choice: the walls' no-slip velocity (``v_ext``)
            vj = J.v_ext
        else:
            vj = J.v
        vz = (I.v[2, i] - vj[2, j]) * dz if dim == 3 else zero
        vx = (I.v[0, i] - vj[0, j]) * dx + (I.v[1, i] - vj[1, j]) * dy + vz
        f = (P.wall_visc if wall else P.visc) * vx / (r * r + P.eps_h2) * grad(r, P) * J.vol[j]
        return add_force(acc, f * dx, f * dy, f * dz)

    return term


def make_mvt(ctx, wall=False, noslip=False):
    """Morris, Fox & Zhu (1997) Laplacian, mu <Lap v> = 2 mu sum_j V_j v_ij
    (x_ij . grad_i W_ij) / (r^2 + eps h^2). (The spec's table prints v_ij . x_ij grad W, the
    Monaghan-Gingold shape; Morris's operator is the one above.)"""
    grad, dim, zero = ctx.grad, ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        if noslip:  # compile-time choice: the walls' no-slip velocity (``v_ext``)
            vj = J.v_ext
        else:
            vj = J.v
        r2 = r * r
        f = (P.wall_visc if wall else P.visc) * r2 * grad(r, P) / (r2 + P.eps_h2) * J.vol[j]
        fz = f * (I.v[2, i] - vj[2, j]) if dim == 3 else zero
        return add_force(acc, f * (I.v[0, i] - vj[0, j]), f * (I.v[1, i] - vj[1, j]), fz)

    return term


def make_boundary_viscosity(ctx, artificial, law="no-slip"):
    """No-slip wall term of the WCSPH-BI spec (MVT and MGVT rows):
    c sum_b (v_i - v_b) / ((x_i - x_b) . n_b) W_ib S_b, with c = ``P.wall_visc`` and the
    denominator regularised as d / (d^2 + eps h^2). d < 0 on the fluid side (n_b points out of
    the fluid), so the term opposes the slip. A particle behind the element's plane (d > 0:
    round a convex corner, beside the next face) takes nothing from it: there 1/d would
    *drive* the slip, and a body moving through still water felt a forward friction from the
    water lagging behind its rear corners (SPHERIC 6: C_D,v -0.14 against +0.20; the fix is
    min(d, 0), no change on a flat or concave wall). For artificial viscosity the same term with
    the equivalent viscosity nu = alpha h c0 / (2 (n + 2)) (Monaghan 2005), times rho_i, acting
    only while the particle approaches the wall.

    ``law = "werner-wengle"``: the wall shear of a turbulent boundary layer that the particles
    do not resolve (Werner & Wengle 1991: u+ = y+ below y+ = 11.81, u+ = 8.3 y+^(1/7) above).
    At a particle y = -d from the element's plane, sliding along it at u_t, the law's shear
    is mu_eff u_t / y with mu_eff / mu = max(1, (y u_t / nu)^(3/4) / 8.3^(7/4)), which the
    term applies to the tangential slip (the normal part keeps mu). Below y+ = 11.81 it is the
    no-slip term itself. With a layer thickness delta (``P.wall_layer`` > 0) the law is read
    at y_l = max(y, delta): the shear of a layer delta thick whose outer speed is the
    particle's, tau = rho (u_t / 8.3)^(7/4) (nu / y_l)^(1/4), so mu_eff / mu =
    max(1, (y_l u_t / nu)^(3/4) / 8.3^(7/4) y / y_l). The particles do not resolve the layer
    (no eddy viscosity makes one), so the first rows slide at about the outer speed; read at
    their own y = dp/2 the law is the shear of a layer dp/2 thick, which grows as dp shrinks."""
    w, dim, zero, dtype = ctx.w, ctx.dim, ctx.zero, ctx.dtype
    turbulent = law == "werner-wengle"
    one, three_quarters, ww, tiny = dtype(1), dtype(0.75), dtype(1.0 / 8.3 ** 1.75), dtype(1e-30)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        ux = I.v[0, i] - J.v[0, j]
        uy = I.v[1, i] - J.v[1, j]
        uz = I.v[2, i] - J.v[2, j] if dim == 3 else zero
        nz = J.n[2, j] if dim == 3 else zero
        # only from the fluid side of the element's plane (a min, not a branch)
        d = min(dx * J.n[0, j] + dy * J.n[1, j] + dz * nz, zero)
        f = P.wall_visc * d / (d * d + P.eps_h2) * w(r, P) * J.elementSize[j]
        if artificial:  # compile-time choice; only while approaching, as a factor 0 or 1
            f *= I.rho[i] * dtype(ux * J.n[0, j] + uy * J.n[1, j] + uz * nz > zero)
        if turbulent:  # compile-time choice: the tangential slip takes the wall law's viscosity
            un = ux * J.n[0, j] + uy * J.n[1, j] + uz * nz
            tx, ty, tz = ux - un * J.n[0, j], uy - un * J.n[1, j], uz - un * nz
            y_l = max(max(-d, P.wall_layer), tiny)  # tiny: a particle behind the plane (d = 0) takes nothing
            re_y = y_l * (tx * tx + ty * ty + tz * tz) ** 0.5 / P.wall_nu
            g = max(one, re_y ** three_quarters * ww * (-d / y_l)) - one
            return add_force(acc, f * (ux + g * tx), f * (uy + g * ty), f * (uz + g * tz))
        return add_force(acc, f * ux, f * uy, f * uz)

    return term


def make_velocity_gradient(ctx, elements=False, shepard=True, noslip=False):
    """Pair term of the velocity gradient G_ab = d v_a / d x_b of fluid particle i and its
    Shepard sum gamma_i (accumulator: G row by row, then gamma). Over fluid neighbours and
    boundary particles (their velocity: the wall's, or the no-slip one extrapolated to them)
    the difference form V_j (v_j - v_i)_a (grad_i W_ij)_b and V_j W_ij; over boundary
    elements the boundary integral's (v_b - v_i)_a n_b,b W_ib S_b (n out of the fluid), which
    completes the truncated support: sum_j V_j (f_j - f_i) grad_i W_ij + sum_b (f_b - f_i)
    n_b W_ib S_b = int grad f W = gamma_i grad f_i (Ferrand et al. 2013). ``shepard=False``
    (boundary particles, whose full support makes gamma 1): no gamma, the store divides by
    nothing, and the pass evaluates no kernel value. ``noslip``: the boundary particles' no-slip
    velocity ``v_ext`` (module docstring)."""
    grad, w, dim, zero = ctx.grad, ctx.w, ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        if noslip:  # compile-time choice: the walls' no-slip velocity (``v_ext``)
            vj = J.v_ext
        else:
            vj = J.v
        ux = vj[0, j] - I.v[0, i]
        uy = vj[1, j] - I.v[1, i]
        uz = vj[2, j] - I.v[2, i] if dim == 3 else zero
        if elements:  # compile-time choice
            s = w(r, P) * J.elementSize[j]
            gx, gy = J.n[0, j] * s, J.n[1, j] * s
            gz = J.n[2, j] * s if dim == 3 else zero
            share = zero
        else:
            g = grad(r, P) * J.vol[j]
            gx, gy, gz = g * dx, g * dy, g * dz
            share = w(r, P) * J.vol[j] if shepard else zero
        return (acc[0] + ux * gx, acc[1] + ux * gy, acc[2] + ux * gz, acc[3] + uy * gx, acc[4] + uy * gy,
                acc[5] + uy * gz, acc[6] + uz * gx, acc[7] + uz * gy, acc[8] + uz * gz, acc[9] + share)

    return term


def make_sps_stress(ctx):
    """(init, store) of the sub-particle-scale stress of fluid particle i from its velocity
    gradient G / gamma (Smagorinsky's eddy viscosity with Yoshizawa's isotropic part, in the
    form of Dalrymple & Rogers 2006 and DualSPHysics): S = (G + G^T) / 2,
    |S| = sqrt(2 S:S), nu_t = (C_s dp)^2 |S|,
    tau / rho = nu_t (2 S - 2/3 tr(S) I) - 2/3 C_I dp^2 |S|^2 I. Stored as tau / rho^2 in ``tau_rho2`` (as
    ``pr`` holds p / rho^2, what the pair term reads), its components xx, xy, yy (2D) or xx,
    xy, xz, yy, yz, zz (3D)."""
    dim, zero, one = ctx.dim, ctx.zero, ctx.dtype(1)
    two, third = ctx.dtype(2), ctx.dtype(1.0 / 3.0)

    @register_jitable
    def init(i, I, P):
        return (zero, zero, zero, zero, zero, zero, zero, zero, zero, zero)

    @register_jitable
    def store(i, I, P, acc):
        q = one / acc[9] if acc[9] > zero else one
        r = one / I.rho[i]
        if dim == 2:  # G = (acc[0] acc[1]; acc[3] acc[4])
            sxx, syy, sxy = acc[0] * q, acc[4] * q, (acc[1] + acc[3]) * q / two
            ss = sxx * sxx + syy * syy + two * sxy * sxy
            mag = math.sqrt(two * ss)
            nut = P.sps_cs2 * mag
            iso = -two * third * nut * (sxx + syy) - P.sps_ci * mag * mag
            c = two * nut * r
            I.tau_rho2[0, i] = c * sxx + iso * r
            I.tau_rho2[1, i] = c * sxy
            I.tau_rho2[2, i] = c * syy + iso * r
        else:
            sxx, syy, szz = acc[0] * q, acc[4] * q, acc[8] * q
            sxy, sxz, syz = (acc[1] + acc[3]) * q / two, (acc[2] + acc[6]) * q / two, (acc[5] + acc[7]) * q / two
            ss = sxx * sxx + syy * syy + szz * szz + two * (sxy * sxy + sxz * sxz + syz * syz)
            mag = math.sqrt(two * ss)
            nut = P.sps_cs2 * mag
            iso = -two * third * nut * (sxx + syy + szz) - P.sps_ci * mag * mag
            c = two * nut * r
            I.tau_rho2[0, i] = c * sxx + iso * r
            I.tau_rho2[1, i] = c * sxy
            I.tau_rho2[2, i] = c * sxz
            I.tau_rho2[3, i] = c * syy + iso * r
            I.tau_rho2[4, i] = c * syz
            I.tau_rho2[5, i] = c * szz + iso * r

    return init, store


def make_sps(ctx):
    """The sub-particle-scale stress's force between fluid particles, rho_i times
    sum_j m_j (tau_i / rho_i^2 + tau_j / rho_j^2) . grad_i W_ij (the pressure term's symmetric
    form with -p I replaced by tau: momentum conserved), from the stored tau / rho^2."""
    grad, dim = ctx.grad, ctx.dim

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        f = I.rho[i] * J.m[j] * grad(r, P)
        xx = I.tau_rho2[0, i] + J.tau_rho2[0, j]
        xy = I.tau_rho2[1, i] + J.tau_rho2[1, j]
        if dim == 2:
            yy = I.tau_rho2[2, i] + J.tau_rho2[2, j]
            return add_force(acc, f * (xx * dx + xy * dy), f * (xy * dx + yy * dy), f * dz)
        xz = I.tau_rho2[2, i] + J.tau_rho2[2, j]
        yy = I.tau_rho2[3, i] + J.tau_rho2[3, j]
        yz = I.tau_rho2[4, i] + J.tau_rho2[4, j]
        zz = I.tau_rho2[5, i] + J.tau_rho2[5, j]
        return add_force(acc, f * (xx * dx + xy * dy + xz * dz), f * (xy * dx + yy * dy + yz * dz),
                         f * (xz * dx + yz * dy + zz * dz))

    return term


MU = Param("dynamicViscosity", 0.0, "dynamic viscosity mu", unit="Pa s", check=NONNEG, spec=True)
#: every viscous term reads the boundary particles' volume and density
WALL_VOLUME = frozenset({"wall_volume"})
SCALE = Param("scaleBVTCoef", 1.0, "scale of the wall viscous term", check=NONNEG, spec=True)
WALL_LAW = Param("wall_law", "no-slip", "the boundary elements' shear: 'no-slip' (the laminar term) or "
                 "'werner-wengle' (a turbulent boundary layer's wall law, Werner & Wengle 1991, for walls "
                 "whose boundary layer the particles do not resolve)", kind="str",
                 check=one_of("no-slip", "werner-wengle"), walls=("elements",))
WALL_LAYER = Param("wall_layer", 0.0, "the turbulent boundary layer's thickness delta the wall law is read at "
                   "(y = max(y, delta)); 0 reads it at each particle's own distance", unit="m", check=NONNEG,
                   walls=("elements",))


def _wall_law_check(m):
    if m.get("wall_law", "no-slip") != "no-slip" and m["dynamicViscosity"] <= 0:
        return ("wall_law", f"{m['wall_law']!r} needs the fluid's viscosity: set dynamicViscosity > 0")
    return None


def _builder(make, artificial=False):
    def build(ctx, q):
        if q.boundary == "elements":
            wall = make_boundary_viscosity(ctx, artificial, q.m.get("wall_law", "no-slip"))
        else:
            wall = make(ctx, wall=True, noslip=q.noslip)
        return Terms([make(ctx)], [wall])
    return build


def _values(coef, physical=False):
    def values(q):
        c = coef(q)
        out = {"visc": c, "wall_visc": c * q.m["scaleBVTCoef"]}
        if physical:  # the wall law's nu and layer
            out["wall_nu"] = q.m["dynamicViscosity"] / q.ph["rho0"]
            out["wall_layer"] = q.m["wall_layer"]
        return out
    return values


def physical_nu(q):
    """nu = mu / rho0 of a physical viscosity."""
    return q.m["dynamicViscosity"] / q.ph["rho0"]


add("viscous", Choice("None", "-", "inviscid"))
add("viscous", Choice(
    "ArtificialViscosity", "WCSPH-BI spec; Monaghan (1992)", "alpha h c0 sum_j m_j psi_ij / rho_ij grad W_ij, approaching pairs",
    params=(Param("alpha", 0.02, "alpha of the artificial viscosity alpha h c0", check=NONNEG, spec=True), SCALE),
    p_fields=("visc", "wall_visc"), values=_values(lambda q: q.m["alpha"] * q.h * q.c0),
    build=_builder(make_artificial_viscosity, artificial=True),
    implies=WALL_VOLUME))
add("viscous", Choice(
    "PhysicalViscosity_MVT", "Morris, Fox & Zhu (1997); WCSPH-BI spec (MVT row)", "2 mu sum_j V_j v_ij x_ij.grad W_ij/(r^2+eps h^2)",
    params=(MU, SCALE, WALL_LAW, WALL_LAYER), p_fields=("visc", "wall_visc", "wall_nu", "wall_layer"),
    values=_values(lambda q: 2.0 * q.m["dynamicViscosity"], physical=True), build=_builder(make_mvt), nu=physical_nu, check=_wall_law_check, implies=WALL_VOLUME))
add("viscous", Choice(
    "PhysicalViscosity_MGVT", "Monaghan & Gingold (1983); WCSPH-BI spec (MGVT row)",
    "2 (n+2) mu sum_j psi_ij grad W_ij V_j", params=(MU, SCALE, WALL_LAW, WALL_LAYER), p_fields=("visc", "wall_visc", "wall_nu", "wall_layer"),
    values=_values(lambda q: 2.0 * (q.dim + 2) * q.m["dynamicViscosity"], physical=True), build=_builder(make_mgvt), nu=physical_nu, check=_wall_law_check,
    implies=WALL_VOLUME))


def _sps_build(ctx, q):
    laminar = _builder(make_mvt)(ctx, q)
    return Terms(laminar.fluid + [make_sps(ctx)], laminar.wall)


def _sps_passes(ctx, q):
    init, store = make_sps_stress(ctx)
    elements = q.boundary == "elements"
    wall = make_velocity_gradient(ctx, elements=elements, shepard=elements, noslip=q.noslip)
    return [FluidPass(init, make_velocity_gradient(ctx, shepard=elements), store, wall=wall, writes=("tau_rho2",))]


def _sps_values(q):
    out = _values(lambda q: 2.0 * q.m["dynamicViscosity"], physical=True)(q)
    out.update(sps_cs2=(q.m["sps_smagorinsky"] * q.dp) ** 2, sps_ci=2.0 / 3.0 * q.m["sps_blin"] * q.dp ** 2)
    return out


add("viscous", Choice(
    "LaminarSPS", "Dalrymple & Rogers (2006); DualSPHysics' Laminar+SPS",
    "the MVT laminar term with mu plus the divergence of the sub-particle-scale stress tau (Smagorinsky "
    "eddy viscosity (C_s dp)^2 |S|, Yoshizawa's isotropic part C_I dp^2 |S|^2), the velocity gradient from "
    "a pass before each interaction",
    params=(MU, SCALE, WALL_LAW, WALL_LAYER,
            Param("sps_smagorinsky", 0.12, "Smagorinsky's constant C_s (the filter width is dp)", check=POS),
            Param("sps_blin", 0.0066, "C_I of the isotropic part (Blin et al. 2002)", check=NONNEG)),
    p_fields=("visc", "wall_visc", "wall_nu", "wall_layer", "sps_cs2", "sps_ci"), values=_sps_values, build=_sps_build,
    nu=physical_nu, check=_wall_law_check, implies=frozenset({"wall_volume", "stress"}), passes=_sps_passes))
