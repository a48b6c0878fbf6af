"""The accumulator of the WCSPH-BI interaction, one tuple per fluid particle i:

    (div, D, fx, fy, fz, gamma)

* ``div``: <div v>_i, bulk plus boundary part;
* ``D``: the diffusive term D_i of the continuity equation (without delta h c0);
* ``f``: the force density -<grad p>_i plus the viscous force density (rho_i times the
  viscous acceleration), so that Dv/Dt = f / (rho_i gamma_i) + g;
* ``gamma``: the Shepard factor sum_j W_ij V_j (consistent schemes).

Terms add to their slots through these helpers, so a term names what it contributes to.
"""
from numba.extending import register_jitable


@register_jitable
def add_div(acc, s):
    return (acc[0] + s, acc[1], acc[2], acc[3], acc[4], acc[5])


@register_jitable
def add_diffusion(acc, s):
    return (acc[0], acc[1] + s, acc[2], acc[3], acc[4], acc[5])


@register_jitable
def add_force(acc, fx, fy, fz):
    return (acc[0], acc[1], acc[2] + fx, acc[3] + fy, acc[4] + fz, acc[5])


@register_jitable
def add_gamma(acc, s):
    return (acc[0], acc[1], acc[2], acc[3], acc[4], acc[5] + s)
