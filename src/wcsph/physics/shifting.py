"""Particle shifting in the bulk with free-surface detection, slot ``shifting``. After each
time step every fluid particle is moved by

  dr_i = -D_i sum_j (1 + R (W_ij / W(dp))^n) grad_i W_ij V_j,   R = 0.2, n = 4,

the concentration-gradient (Fickian) shift of Lind, Xu, Stansby & Rogers (2012) with the
anti-clumping term of Monaghan (2000) that Lind and Sun et al. use, where

* ``Lind``: D_i = A h |v_i| dt (Lind et al. 2012, A = ``shifting_A``, 1 to 6 in the paper);
* ``DeltaPlus``: D = CFL Ma (2h)^2 = 4 h U dt (Sun, Colagrossi, Marrone & Zhang 2017,
  delta+-SPH, with Ma = U/c0 and CFL = c0 dt/h), U the largest fluid speed of the step.

**Free surface** (after Lind et al. 2012): a particle whose position divergence
div r_i = -sum_j x_ij . grad_i W_ij V_j (= dim in the bulk) is below
``shifting_surface_threshold`` (default dim - 0.25: the surface row and the one below it)
is not shifted out of the fluid: the component of the shift along
n_i = -sum_j grad_i W_ij V_j / |...| (out of the fluid) is removed where it is positive.
(Removing only the surface row's normal shift, Lind's rule, let the row below move up into
it: a WCSPH-BI hydrostatic column with delta+ shifting stood 4 % too high in floor pressure.)

**Walls** complete every sum: boundary particles as neighbours, boundary elements as the
boundary integral (``make_shift_boundary``), so a wall neither pulls fluid towards it nor
reads as a free surface. Without that completion the particles along the side walls of a
WCSPH-BI hydrostatic tank were shifted along them and drove a circulation that grew to
0.29 m/s in 2 s; with it the tank stays at rest (0.02 m/s, 1 % of sqrt(g H)).

``shifting_near_walls = "none"`` instead leaves a particle with a wall within its kernel
support where it is (TNL-SPH's PST does so): next to a moving body the shift then cannot
work against the wall corrections. In SPHERIC test 6 with the corrections' default
(``minimalDistanceFactor`` 0.5) the two together raised the closed box's mean pressure
without bound (from p0 = 5 Pa to 29 Pa in 6 s at 40 particles across; docs/accuracy.md §4).

A shift is capped at ``shifting_max`` dp. A shifted particle takes the density of its new
place, rho + dr . grad rho (continuity density; Lind et al. 2012 correct the fields so).
Velocities are not corrected (delta+-SPH neglects that term too).
"""
import math

from numba.extending import register_jitable

from .registry import NONNEG, POS, Choice, Param, add, one_of
from . import AfterStepPass

R_TENSILE, N_TENSILE = 0.2, 4


def make_shift_term(ctx, density_gradient):
    """Accumulator (gx, gy, gz, nx, ny, nz, div r, rx, ry, rz, walls): the weighted gradient,
    the plain one (for the normal), the position divergence and, with ``density_gradient``
    (fluid neighbours, continuity density), sum_j (rho_j - rho_i) grad_i W_ij V_j for the
    shifted particle's density (the three stay zero otherwise, and the compiler drops them);
    ``walls``, the number of wall neighbours, stays as it is (``make_shift_wall_particles``)."""
    w, grad = ctx.w, ctx.grad
    rt = ctx.dtype(R_TENSILE)
    one, zero = ctx.dtype(1), ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        g = grad(r, P) * J.vol[j]
        q = w(r, P) * P.shift_w_dp_inv
        q2 = q * q
        t = (one + rt * q2 * q2) * g
        d = (J.rho[j] - I.rho[i]) * g if density_gradient else zero
        return (acc[0] + t * dx, acc[1] + t * dy, acc[2] + t * dz, acc[3] + g * dx, acc[4] + g * dy,
                acc[5] + g * dz, acc[6] - g * r * r, acc[7] + d * dx, acc[8] + d * dy, acc[9] + d * dz, acc[10])

    return term


def make_shift_wall_particles(ctx):
    """Boundary particles complete the sums as fluid neighbours do, and count in ``walls``."""
    fluid, one = make_shift_term(ctx, False), ctx.dtype(1)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        a = fluid(i, j, dx, dy, dz, r, I, J, P, acc)
        return (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10] + one)

    return term


def make_shift_boundary(ctx):
    """Boundary elements complete the sums as a boundary integral (the WCSPH-BI identity
    sum_j grad_i W_ij V_j + sum_b n_b W_ib S_b = 0 for a full support): n_b W S_b in both
    gradients and (x_b - x_i) . n_b W S_b in div r, so that a wall neither pulls particles in
    nor looks like a free surface."""
    w, dim, zero, one = ctx.w, ctx.dim, ctx.zero, ctx.dtype(1)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        ws = w(r, P) * J.elementSize[j]
        nx, ny = J.n[0, j] * ws, J.n[1, j] * ws
        nz = J.n[2, j] * ws if dim == 3 else zero
        return (acc[0] + nx, acc[1] + ny, acc[2] + nz, acc[3] + nx, acc[4] + ny, acc[5] + nz,
                acc[6] - (dx * nx + dy * ny + dz * nz), acc[7], acc[8], acc[9], acc[10] + one)

    return term


def make_shift_store(ctx, per_particle, continuity, near_walls=True):
    """``near_walls`` False: a particle with a wall neighbour is not shifted."""
    dim, zero, one = ctx.dim, ctx.zero, ctx.dtype(1)
    tiny = ctx.dtype(1e-30)

    @register_jitable
    def init(i, I, P):
        return (zero, zero, zero, zero, zero, zero, zero, zero, zero, zero, zero)

    @register_jitable
    def store(i, I, P, acc):
        if per_particle:
            vz = I.v[2, i] if dim == 3 else zero
            d = P.shift_d * math.sqrt(I.v[0, i] ** 2 + I.v[1, i] ** 2 + vz * vz)
        else:
            d = P.shift_d * P.vmax
        sx, sy, sz = -d * acc[0], -d * acc[1], -d * acc[2]
        if dim == 2:
            sz = zero
        if acc[6] < P.shift_surface:  # near the free surface: never out of the fluid
            nx, ny, nz = -acc[3], -acc[4], -acc[5] if dim == 3 else zero
            nn = math.sqrt(nx * nx + ny * ny + nz * nz)
            k = max((sx * nx + sy * ny + sz * nz) / max(nn * nn, tiny), zero)
            sx, sy, sz = sx - k * nx, sy - k * ny, sz - k * nz
        s = math.sqrt(sx * sx + sy * sy + sz * sz)
        c = min(one, P.shift_max / max(s, tiny))
        if not near_walls and acc[10] > zero:
            c = zero
        sx, sy, sz = c * sx, c * sy, c * sz
        I.corr[0, i] = sx
        I.corr[1, i] = sy
        if dim == 3:
            I.corr[2, i] = sz
        if continuity:  # the density carried to the new position: rho + dr . grad rho (Lind et al. 2012)
            I.rho_corr[i] = I.rho[i] + sx * acc[7] + sy * acc[8] + (sz * acc[9] if dim == 3 else zero)

    return init, store


def make_shift_apply(ctx, continuity):
    """x += dr; with continuity density, rho += dr . grad rho."""
    dim = ctx.dim

    @register_jitable
    def apply(i, I, P):
        for d in range(dim):
            I.x[d, i] += I.corr[d, i]
        if continuity:
            I.rho[i] = I.rho_corr[i]

    return apply


def _build(per_particle):
    def build(ctx, q):
        init, store = make_shift_store(ctx, per_particle, q.continuity, q.m["shifting_near_walls"] == "complete")
        wall = make_shift_wall_particles(ctx) if q.boundary == "particles" else make_shift_boundary(ctx)
        return AfterStepPass(init, make_shift_term(ctx, q.continuity), store, make_shift_apply(ctx, q.continuity),
                          wall=wall)
    return build


def _values(q):
    thr = q.m["shifting_surface_threshold"] or q.dim - 0.25
    return {"shift_w_dp_inv": 1.0 / float(q.kernel_numpy(q.dp)), "shift_surface": thr,
            "shift_max": q.m["shifting_max"] * q.dp}


SURFACE = Param("shifting_surface_threshold", 0.0, "div r below which a particle is near the free surface "
                "(not shifted outwards); 0: dim - 0.25", check=NONNEG)
MAX = Param("shifting_max", 0.2, "largest shift per step, in dp", check=POS)
NEAR_WALLS = Param("shifting_near_walls", "complete", "'complete': walls complete the sums (a particle "
                   "by a wall is shifted along it); 'none': a particle with a wall within its kernel "
                   "support is not shifted (TNL-SPH's PST)", kind="str", check=one_of("complete", "none"))
FIELDS = ("shift_d", "shift_w_dp_inv", "shift_surface", "shift_max")

add("shifting", Choice("None", "-", "no shifting"))
add("shifting", Choice(
    "Lind", "Lind, Xu, Stansby & Rogers (2012)", "dr_i = -A h |v_i| dt sum_j (1 + R (W/W(dp))^4) grad W_ij V_j",
    params=(Param("shifting_A", 2.0, "A of D = A h |v| dt", check=POS), SURFACE, MAX, NEAR_WALLS), p_fields=FIELDS,
    values=_values, step_values=lambda q: {"shift_d": (q.m["shifting_A"] * q.h, 1)}, build=_build(True),
    implies=frozenset({"wall_volume"})))
add("shifting", Choice(
    "DeltaPlus", "Sun, Colagrossi, Marrone & Zhang (2017), delta+-SPH",
    "dr_i = -CFL Ma (2h)^2 sum_j (1 + R (W/W(dp))^4) grad W_ij V_j",
    params=(SURFACE, MAX, NEAR_WALLS), p_fields=FIELDS, values=_values,
    step_values=lambda q: {"shift_d": (4.0 * q.h, 1)}, build=_build(False),
    implies=frozenset({"wall_volume", "speed"})))

