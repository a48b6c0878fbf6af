"""Particle shifting in the bulk with free-surface detection, slot ``shifting``. After each
time step every fluid particle is moved by

  dr_i = -D_i sum_j (1 + R (W_ij / W(dp))^n) grad_i W_ij V_j,   R = 0.2, n = 4,

the concentration-gradient (Fickian) shift of Lind, Xu, Stansby & Rogers (2012) with the
anti-clumping term of Monaghan (2000) that Lind and Sun et al. use, where

* ``Lind``: D_i = A h |v_i| dt (Lind et al. 2012, A = ``shifting_A``, 1 to 6 in the paper);
* ``DeltaPlus``: D = CFL Ma (2h)^2 = 4 h U dt with U the largest fluid speed (Sun, Colagrossi,
  Marrone & Zhang 2017, delta+-SPH, with Ma = U/c0 and CFL = c0 dt/h).

**Free surface** (Lind et al. 2012): a particle whose position divergence
div r_i = -sum_j x_ij . grad_i W_ij V_j (= dim in the bulk) is below
``shifting_surface_threshold`` (default dim - 0.5) is shifted only along the surface: the
component along n_i = -sum_j grad_i W_ij V_j / |...| (out of the fluid) is removed. Boundary
particles count as neighbours (so walls do not pull fluid in); next to boundary elements the
missing neighbours make a particle look like a surface one, so it slides along the wall.
A shift is capped at ``shifting_max`` dp. Fields are not corrected for the shift (delta+-SPH
neglects that term too in weakly compressible flow).
"""
import math

from numba.extending import register_jitable

from ..registry import NONNEG, POS, Choice, Param, add
from . import Correction, make_apply

R_TENSILE, N_TENSILE = 0.2, 4


def make_shift_term(ctx):
    """Accumulator (gx, gy, gz, nx, ny, nz, div r): the weighted gradient, the plain one (for
    the normal) and the position divergence."""
    w, grad = ctx.w, ctx.grad
    rt = ctx.dtype(R_TENSILE)
    one = ctx.dtype(1)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        g = grad(r, P) * J.vol[j]
        q = w(r, P) * P.shift_w_dp_inv
        q2 = q * q
        t = (one + rt * q2 * q2) * g
        return (acc[0] + t * dx, acc[1] + t * dy, acc[2] + t * dz, acc[3] + g * dx, acc[4] + g * dy,
                acc[5] + g * dz, acc[6] - g * r * r)

    return term


def make_shift_store(ctx, per_particle):
    dim, zero, one = ctx.dim, ctx.zero, ctx.dtype(1)
    tiny = ctx.dtype(1e-30)

    @register_jitable
    def init(i, I, P):
        return (zero, zero, zero, zero, zero, zero, zero)

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
        if acc[6] < P.shift_surface:  # free surface: only along it
            nx, ny, nz = -acc[3], -acc[4], -acc[5] if dim == 3 else zero
            nn = math.sqrt(nx * nx + ny * ny + nz * nz)
            k = (sx * nx + sy * ny + sz * nz) / max(nn * nn, tiny)
            sx, sy, sz = sx - k * nx, sy - k * ny, sz - k * nz
        s = math.sqrt(sx * sx + sy * sy + sz * sz)
        c = min(one, P.shift_max / max(s, tiny))
        I.corr[0, i] = c * sx
        I.corr[1, i] = c * sy
        if dim == 3:
            I.corr[2, i] = c * sz

    return init, store


def _build(per_particle):
    def build(ctx, q):
        init, store = make_shift_store(ctx, per_particle)
        term = make_shift_term(ctx)
        return Correction(init, term, store, make_apply(ctx, "x", False),
                          wall=term if q.boundary == "particles" else None)
    return build


def _values(q):
    thr = q.m["shifting_surface_threshold"] or q.dim - 0.5
    return {"shift_w_dp_inv": 1.0 / float(q.kernel_numpy(q.dp)), "shift_surface": thr,
            "shift_max": q.m["shifting_max"] * q.dp}


SURFACE = Param("shifting_surface_threshold", 0.0, "div r below which a particle is on the free surface; "
                "0: dim - 0.5", check=NONNEG)
MAX = Param("shifting_max", 0.2, "largest shift per step, in dp", check=POS)
FIELDS = ("shift_d", "shift_w_dp_inv", "shift_surface", "shift_max")

add("shifting", Choice("None", "-", "no shifting"))
add("shifting", Choice(
    "Lind", "Lind, Xu, Stansby & Rogers (2012)", "dr_i = -A h |v_i| dt sum_j (1 + R (W/W(dp))^4) grad W_ij V_j",
    params=(Param("shifting_A", 2.0, "A of D = A h |v| dt", check=POS), SURFACE, MAX), p_fields=FIELDS,
    values=_values, step_values=lambda q, dt: {"shift_d": q.m["shifting_A"] * q.h * dt}, build=_build(True)))
add("shifting", Choice(
    "DeltaPlus", "Sun, Colagrossi, Marrone & Zhang (2017), delta+-SPH",
    "dr_i = -CFL Ma (2h)^2 sum_j (1 + R (W/W(dp))^4) grad W_ij V_j", params=(SURFACE, MAX), p_fields=FIELDS,
    values=_values, step_values=lambda q, dt: {"shift_d": 4.0 * q.h * dt}, build=_build(False)))

