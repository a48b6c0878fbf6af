"""The accumulator of the interaction pass (the momentum and continuity equations), one tuple
per fluid particle i, the same for every model:

    (div, D, fx, fy, fz, ax, ay, az, shepard)

* ``div``: <div v>_i (continuity density only), bulk plus wall part;
* ``D``: the diffusive term D_i of the continuity equation (without delta h c0);
* ``f``: force density terms (-<grad p>_i of the WCSPH-BI forms, viscous forces), so that
  Dv/Dt gets f / (rho_i shepard_i);
* ``a``: acceleration terms (the m_j (p_i/rho_i^2 + p_j/rho_j^2) forms, XSPH on the momentum),
  added to Dv/Dt as they are;
* ``shepard``: the Shepard factor gamma_i = sum_j W_ij V_j of the consistent wall model.

Terms add to their slots through these helpers, so a term names what it contributes to. A
slot no term of a case writes stays a constant zero, which the compiler removes.
"""
from numba.extending import register_jitable


@register_jitable
def add_div(acc, s):
    return (acc[0] + s, acc[1], acc[2], acc[3], acc[4], acc[5], acc[6], acc[7], acc[8])


@register_jitable
def add_diffusion(acc, s):
    return (acc[0], acc[1] + s, acc[2], acc[3], acc[4], acc[5], acc[6], acc[7], acc[8])


@register_jitable
def add_force(acc, fx, fy, fz):
    return (acc[0], acc[1], acc[2] + fx, acc[3] + fy, acc[4] + fz, acc[5], acc[6], acc[7], acc[8])


@register_jitable
def add_accel(acc, ax, ay, az):
    return (acc[0], acc[1], acc[2], acc[3], acc[4], acc[5] + ax, acc[6] + ay, acc[7] + az, acc[8])


@register_jitable
def add_shepard(acc, s):
    return (acc[0], acc[1], acc[2], acc[3], acc[4], acc[5], acc[6], acc[7], acc[8] + s)


class Terms:
    """What a choice contributes to the interaction pass: its pair terms over fluid
    neighbours and over wall neighbours (either list may be empty)."""

    def __init__(self, fluid=(), wall=()):
        self.fluid = list(fluid)
        self.wall = list(wall)
