"""Shepard renormalization of the consistent WCSPH-BI schemes, and the boundary pressure they
interpolate from the fluid."""
from numba.extending import register_jitable

from .interaction import add_shepard


def make_shepard(ctx):
    """gamma_i = sum_j W_ij V_j over fluid particles (the self pair included): 1 in the bulk,
    less near walls and the free surface. Stored as the field ``shepard``."""
    w = ctx.w

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        return add_shepard(acc, w(r, P) * J.vol[j])

    return term


def make_hydrostatic_sample(ctx):
    """(start, sample): p_j carried from fluid particle j to the point x_i = x_j + (dx, dy, dz)
    of wall I along the pressure gradient of a fluid at rest relative to the wall,
    p_j + rho_j (g - a_i) . (dx, dy, dz), a_i the wall's acceleration (Adami, Hu & Adams 2012,
    eq. 27; ``motion`` gives a_i, zero for a fixed wall or a constant velocity). ``start(i, I,
    P)`` gives g - a_i once per wall point (a pass carries it in its accumulator), and
    ``sample(j, dx, dy, dz, J, e)`` the carried pressure with e = g - a_i."""
    dim, zero = ctx.dim, ctx.zero

    @register_jitable
    def start(i, I, P):
        return (P.gx - I.a[0, i], P.gy - I.a[1, i], P.gz - I.a[2, i] if dim == 3 else zero)

    @register_jitable
    def sample(j, dx, dy, dz, J, e):
        gz = e[2] * dz if dim == 3 else zero
        return J.p[j] + J.rho[j] * (e[0] * dx + e[1] * dy + gz)

    return start, sample


def make_boundary_interpolation(ctx):
    """Wall point b (a boundary element or wall particle), fluid neighbour j: accumulate
    (sum_j (p_j + rho_j (g - a_b) . x_bj) W V_j, sum_j rho_j W V_j, sum_j W V_j), carrying
    g - a_b in the accumulator's last three slots (``make_boundary_store``'s init puts it
    there). Divided by the third (Shepard), these give the wall pressure with the correction
    of Adami, Hu & Adams (2012) for gravity and the wall's acceleration a_b, and the wall
    density; (dx, dy, dz) = x_b - x_j."""
    w = ctx.w
    sample = make_hydrostatic_sample(ctx)[1]

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        wv = w(r, P) * J.vol[j]
        e = (acc[3], acc[4], acc[5])
        return (acc[0] + sample(j, dx, dy, dz, J, e) * wv, acc[1] + J.rho[j] * wv, acc[2] + wv,
                acc[3], acc[4], acc[5])

    return term


def make_boundary_store(ctx):
    """p_b and rho_b of an element from the interpolation sums, clamped at p0 and rho0 as
    TNL-SPH clamps the wall density (an element by a thin or splashing fluid layer would
    otherwise get a negative pressure and pull the fluid into the wall); p0, rho0 with no
    fluid neighbour."""
    zero = ctx.zero
    start = make_hydrostatic_sample(ctx)[0]

    @register_jitable
    def init(i, I, P):
        e = start(i, I, P)
        return (zero, zero, zero, e[0], e[1], e[2])

    @register_jitable
    def store(i, I, P, acc):
        if acc[2] > zero:
            I.p[i] = max(acc[0] / acc[2], P.p0)
            I.rho[i] = max(acc[1] / acc[2], P.rho0)
        else:
            I.p[i] = P.p0
            I.rho[i] = P.rho0

    return init, store


def make_wall_pressure(ctx):
    """The pressure of wall particle i (set I: the walls) from its fluid neighbours, as Adami,
    Hu & Adams (2012) eq. 27 give it for dummy particles (fixed walls): the interpolation of
    ``make_boundary_interpolation``, clamped at 0 as the classic model clamps the fluid's
    pressure, 0 where no fluid is near; ``pr`` = p_w / rho_w^2 with rho_w the Shepard mean of
    the neighbours' density. Pressure mirroring (p_w = p_i) misses the hydrostatic rise over
    the one or two spacings between a particle and the wall particles it sees, so the walls
    push too little and a still column stands on a floor pressure 3-4 % above its weight;
    these wall pressures carry it. Returns (init, pair, store); the store writes ``p``, ``pr``."""
    zero = ctx.zero
    init = make_boundary_store(ctx)[0]

    @register_jitable
    def store(i, I, P, acc):
        if acc[2] > zero:
            p = max(acc[0] / acc[2], zero)
            rho = acc[1] / acc[2]
            I.p[i] = p
            I.pr[i] = p / (rho * rho)
        else:
            I.p[i] = zero
            I.pr[i] = zero

    return init, make_boundary_interpolation(ctx), store


def make_noslip_velocity(ctx):
    """The no-slip wall velocity of Adami, Hu & Adams (2012), eq. 22-23, for wall particle i
    (set I: the walls) from its fluid neighbours j: v_ext,i = 2 v_w,i - sum_j v_j W_ij V_j /
    sum_j W_ij V_j (the wall's own velocity where no fluid is near). The wall terms then read
    v_ext as v_b, which puts the no-slip condition on the wall surface rather than at the
    wall particles' depth. Returns (init, pair, store); the store writes ``v_ext``."""
    w, zero, dim = ctx.w, ctx.zero, ctx.dim

    @register_jitable
    def init(i, I, P):
        return (zero, zero, zero, zero)

    @register_jitable
    def pair(i, j, dx, dy, dz, r, I, J, P, acc):
        wv = w(r, P) * J.vol[j]
        vz = J.v[2, j] * wv if dim == 3 else zero
        return (acc[0] + wv, acc[1] + J.v[0, j] * wv, acc[2] + J.v[1, j] * wv, acc[3] + vz)

    @register_jitable
    def store(i, I, P, acc):
        s = acc[0]
        for d in range(dim):
            I.v_ext[d, i] = I.v[d, i] + I.v[d, i] - acc[1 + d] / s if s > zero else I.v[d, i]

    return init, pair, store
