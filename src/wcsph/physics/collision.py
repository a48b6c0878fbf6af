"""Dynamic particle collision (DPC), Jandaghian, Siaben & Shakibaeinia (2021),
arXiv:2110.10076, as the third spec writes it. Slot ``collision``. After each time step:

  dv_i = sum_j k_ij m_j/(m_i + m_j) v^coll_ij
         + dt/rho_i sum_j phi_ij 2 V_j/(V_i + V_j) p^b_ij/(r^2 + eta^2) x_ij

* approaching pairs (v_ij . x_ij < 0): v^coll_ij = (v_ij . x_ij)/(r^2 + eta^2) x_ji, phi = 0:
  an inelastic collision that removes (k_ij = 1) the pair's approach velocity;
* other pairs: v^coll = 0, phi = 1: a repulsive pressure p^b_ij = p~_ij chi_ij with
  p~_ij = max(min(lambda |p_i + p_j|, lambda p_max), p_min);
* chi_ij = sqrt(w(r, l0)/w(l0/2, l0)), w the case's kernel with support l0 (so only pairs
  closer than l0 take part), and k_ij = chi_ij for l0/2 <= r < l0, 1 below: k = min(chi, 1).

Fluid pairs only; eta^2 = ``eps`` h^2. The velocity change is stored, then applied, so that
every pair sees the velocities of the end of the step.
"""
import math

from numba.extending import register_jitable

from .registry import NONNEG, Choice, Param, add
from . import AfterStepPass, make_apply, make_store_corr, vector_init


def make_dpc(ctx):
    w, dim, zero, one, two = ctx.w, ctx.dim, ctx.zero, ctx.dtype(1), ctx.dtype(2)
    dtype = ctx.dtype

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        chi = math.sqrt(w(r * P.dpc_scale, P) * P.dpc_w_half_inv)
        k = min(chi, one)
        vz = (I.v[2, i] - J.v[2, j]) * dz if dim == 3 else zero
        vr = (I.v[0, i] - J.v[0, j]) * dx + (I.v[1, i] - J.v[1, j]) * dy + vz
        r2e = r * r + P.eps_h2
        # collision: k m_j/(m_i + m_j) (v_ij . x_ij)/(r^2 + eta^2) x_ji, approaching pairs only
        c = -k * J.m[j] / (I.m[i] + J.m[j]) * min(vr, zero) / r2e
        # repulsion: phi = 1 for the others
        pt = max(min(P.dpc_lambda * abs(I.p[i] + J.p[j]), P.dpc_lambda_pmax), P.dpc_pmin)
        phi = dtype(vr >= zero)
        vi, vj = I.vol[i], J.vol[j]
        s = P.dt / I.rho[i] * phi * two * vj / (vi + vj) * pt * chi / r2e
        f = c + s
        return (acc[0] + f * dx, acc[1] + f * dy, acc[2] + f * dz)

    return term


def _values(q):
    l0 = q.m["dpc_l0"] or q.dp
    w_np = q.kernel_numpy
    pmax = q.m["dpc_pmax"] or 0.01 * q.rho0 * q.c0 ** 2
    # w(r * h/(l0/2)) is the kernel shape at q = r/(l0/2): support l0
    return {"dpc_scale": q.h / (0.5 * l0), "dpc_w_half_inv": 1.0 / float(w_np(q.h)),
            "dpc_lambda": q.m["dpc_lambda"], "dpc_lambda_pmax": q.m["dpc_lambda"] * pmax, "dpc_pmin": q.m["dpc_pmin"]}


add("collision", Choice("None", "-", "no collision correction"))
add("collision", Choice(
    "DPC", "Jandaghian, Siaben & Shakibaeinia (2021), arXiv:2110.10076; third spec",
    "dv_i = sum k_ij m_j/(m_i+m_j) v^coll_ij + dt/rho_i sum phi_ij 2V_j/(V_i+V_j) p^b_ij/(r^2+eta^2) x_ij",
    params=(Param("dpc_l0", 0.0, "collision distance l0; 0: dp", unit="m", check=NONNEG),
            Param("dpc_lambda", 0.1, "lambda of the repulsive pressure", check=NONNEG),
            Param("dpc_pmin", 0.0, "p_min of the repulsive pressure", unit="Pa", check=NONNEG),
            Param("dpc_pmax", 0.0, "p_max of the repulsive pressure; 0: 0.01 rho0 c0^2", unit="Pa", check=NONNEG)),
    p_fields=("dpc_scale", "dpc_w_half_inv", "dpc_lambda", "dpc_lambda_pmax", "dpc_pmin"), values=_values,
    build=lambda ctx, q: AfterStepPass(vector_init(ctx), make_dpc(ctx), make_store_corr(ctx), make_apply(ctx, "v", False))))
