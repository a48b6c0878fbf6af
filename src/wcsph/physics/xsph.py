"""XSPH velocity smoothing (Monaghan 1989), slot ``xsph``, in two forms:

* ``momentum``: as Becker & Teschner (2007) and SPlisHSPlasH apply it, an acceleration
  epsilon/dt sum_j V_j (v_j - v_i) W_ij, so that one symplectic Euler step smooths the
  velocity itself; over boundary particles with ``wall_xsph`` (towards the wall velocity);
* ``position``: as the third spec writes it, the advection velocity v_i + v^_i with
  v^_i = -epsilon sum_j m_j v_ij / rho_ij W_ij (rho_ij the pair's mean density): positions move
  with it, the momentum equation is untouched. Applied after each step as
  x_i += dt v^_i from the step's end velocities (first order in dt, like XSPH itself).
"""
from numba.extending import register_jitable

from .registry import UNIT, Choice, Param, add
from . import AfterStepPass, make_apply, make_store_corr, vector_init
from .interaction import Terms, add_accel

EPSILON = Param("xsph_epsilon", 0.1, "epsilon of XSPH", check=UNIT)


def make_xsph(ctx, wall=False):
    """a_i += epsilon/dt sum_j V_j (v_j - v_i) W_ij (``P.xsph_dt`` = epsilon/dt), over fluid
    neighbours; with ``wall``, over boundary particles with V = Psi/rho0 and
    ``P.wall_xsph_dt`` = wall_xsph/dt (SPlisHSPlasH's boundary viscosity for Akinci walls)."""
    kernel_w, dim, zero = ctx.w, ctx.dim, ctx.zero

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        if wall:  # a compile-time choice; the classic wall view has Psi only
            f = P.wall_xsph_dt * J.psi[j] * P.rho0_inv * kernel_w(r, P)
        else:
            f = P.xsph_dt * J.vol[j] * kernel_w(r, P)
        fz = f * (J.v[2, j] - I.v[2, i]) if dim == 3 else zero
        return add_accel(acc, f * (J.v[0, j] - I.v[0, i]), f * (J.v[1, j] - I.v[1, i]), fz)

    return term


def make_xsph_position(ctx):
    """v^_i = epsilon sum_j m_j (v_j - v_i) / rho_ij W_ij, rho_ij = (rho_i + rho_j)/2."""
    kernel_w, dim, zero, two = ctx.w, ctx.dim, ctx.zero, ctx.dtype(2)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        f = P.xsph_epsilon * two * J.m[j] / (I.rho[i] + J.rho[j]) * kernel_w(r, P)
        fz = f * (J.v[2, j] - I.v[2, i]) if dim == 3 else zero
        return (acc[0] + f * (J.v[0, j] - I.v[0, i]), acc[1] + f * (J.v[1, j] - I.v[1, i]), acc[2] + fz)

    return term


def _momentum(ctx, q):
    wall = [make_xsph(ctx, wall=True)] if q.boundary == "particles" and q.m["wall_xsph"] > 0 else []
    return Terms([make_xsph(ctx)], wall)


add("xsph", Choice("None", "-", "no velocity smoothing"))
add("xsph", Choice(
    "momentum", "Monaghan (1989) as Becker & Teschner (2007) apply it (SPlisHSPlasH)",
    "a_i += epsilon/dt sum_j V_j (v_j - v_i) W_ij",
    params=(EPSILON, Param("wall_xsph", 0.0, "epsilon towards the wall velocity over boundary particles",
                           check=UNIT, walls=("particles",))),
    p_fields=("xsph_dt", "wall_xsph_dt"),
    step_values=lambda q: {"xsph_dt": (q.m["xsph_epsilon"], -1), "wall_xsph_dt": (q.m["wall_xsph"], -1)},
    build=_momentum))
add("xsph", Choice(
    "position", "third spec, XSPH correction (Monaghan 1989)", "dx_i/dt = v_i - epsilon sum_j m_j v_ij/rho_ij W_ij",
    params=(EPSILON,), p_fields=("xsph_epsilon",), values=lambda q: {"xsph_epsilon": q.m["xsph_epsilon"]},
    build=lambda ctx, q: AfterStepPass(vector_init(ctx), make_xsph_position(ctx), make_store_corr(ctx),
                                    make_apply(ctx, "x", True))))
