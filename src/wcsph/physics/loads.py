"""The fluid's load on boundary elements: what a wall, an obstacle or a moving body feels.

One pass over the elements b with their fluid neighbours j gives each element its load
F_b = p_b n_b S_b + T_b:

* p_b, the wall's own pressure: the Shepard interpolation of the fluid's pressure with the
  correction of Adami, Hu & Adams (2012), p_b = sum_j (p_j + rho_j (g - a_b) . (x_b - x_j))
  W_bj V_j / sum_j W_bj V_j (a_b the element's acceleration) (0 where the element is dry, sum_j W V_j below ``DRY``), not
  clamped (suction behind a moving body is part of its drag). Normalized per element, a
  uniform pressure loads a closed body with exactly p sum_b n_b S_b = 0 however the particles
  lie: the sum over particles of the wall pressure term, which the fluid's momentum sees,
  carries the background pressure times the particles' disorder (with p0 = 5 rho U^2 in
  SPHERIC test 6, ten times the dynamic pressure);
* T_b, the shear: with a physical viscosity, the reaction of its wall term on each
  neighbour, -sum_j V_j f_visc,jb: the wall shear stress integrated over the element
  (Couette flow's mu U / L to 0.1 % in both wall schemes, and the start-up's within 1.3 %
  once the boundary layer is 1.4 h thick; ``tests/boundaries/test_boundaries.py``). The
  consistent scheme divides each particle's whole derivative by its Shepard factor gamma_j
  (about 0.75 in the first row), the bulk's viscous sum too, so there the fluid's share of
  the wall term, V_j f / gamma_j, is not the shear: taken as the load it read Couette's
  33 % high and SPHERIC 6's friction 23 % high. The artificial viscosity's wall term is no
  stress but a damping of the approach to the wall (it acts on approaching particles only):
  the body takes what the fluid feels of it, -sum_j V_j / gamma_j f_jb, so that the push
  is mutual (a floating cylinder entering water, Fekken 2004, is 4.5 % from the experiment
  so and 7.1 % with the undivided sum).

Summed over a body's elements these give its force, and with the lever arms x_b - c its torque.
"""
from numba.extending import register_jitable

from .renormalization import make_hydrostatic_sample

#: below this kernel sum (sum_j W V_j: about 1 inside the fluid, 1/2 on a wall) an element, or a
#: pressure sensor (``io.probes``), is dry
DRY = 0.1


@register_jitable
def measured(i, I, P):
    """Whether wall point i belongs to a body whose load is asked for (the walls' ``measured``
    field): the ``keep`` of the load passes, which leave the other points' loads as they were."""
    return I.measured[i] != 0


def make_element_loads(ctx, shear, shared=False):
    """(init, pair, store) of the load pass: I the elements (``load`` written), J the fluid;
    ``shear``: the viscous slot's wall term (a pair term over fluid i, element j, writing the
    interaction accumulator's force slots) or None; ``shared``: the body takes the fluid's
    share of it, V_j / gamma_j (the consistent scheme with a viscosity that is no stress)."""
    w, dim, zero = ctx.w, ctx.dim, ctx.zero
    dry = ctx.dtype(DRY)
    start, sample = make_hydrostatic_sample(ctx)
    if shear is None:  # inviscid: no friction
        @register_jitable
        def shear(i, j, dx, dy, dz, r, I, J, P, acc):
            return acc

    @register_jitable
    def init(i, I, P):
        e = start(i, I, P)  # g - a_b, carried in the last three slots
        return (zero, zero, zero, zero, zero, e[0], e[1], e[2])

    @register_jitable
    def pair(i, j, dx, dy, dz, r, I, J, P, acc):
        wv = w(r, P) * J.vol[j]
        p = sample(j, dx, dy, dz, J, (acc[5], acc[6], acc[7]))
        # the fluid's friction from this element, reversed
        f = shear(j, i, -dx, -dy, -dz, r, J, I, P, (zero, zero, zero, zero, zero, zero, zero, zero, zero))
        k = J.vol[j] / J.shepard[j] if shared and J.shepard[j] > zero else J.vol[j]
        return (acc[0] + p * wv, acc[1] + wv, acc[2] - k * f[2], acc[3] - k * f[3], acc[4] - k * f[4],
                acc[5], acc[6], acc[7])

    @register_jitable
    def store(i, I, P, acc):
        p = acc[0] / acc[1] if acc[1] >= dry else zero
        s = p * I.elementSize[i]
        I.load[0, i] = s * I.n[0, i] + acc[2]
        I.load[1, i] = s * I.n[1, i] + acc[3]
        if dim == 3:
            I.load[2, i] = s * I.n[2, i] + acc[4]

    return init, pair, store


def make_particle_loads(ctx, wall_term):
    """(init, pair, store) of the load pass of boundary particles: I the wall particles
    (``load`` written), J the fluid; ``wall_term`` the model's wall terms composed (a pair term
    over fluid i, wall particle j, writing the interaction accumulator). The load on wall
    particle k is minus what it does to its fluid neighbours, -sum_j m_j a_jk with
    m_j a_jk = V_j f[2:5] + m_j f[5:8] (the force and acceleration slots, as the interaction's
    store reads them): the reaction of exactly the wall force the fluid feels, pressure and
    friction, one pass over the wall particles."""
    zero, dim = ctx.zero, ctx.dim

    @register_jitable
    def init(i, I, P):
        return (zero, zero, zero)

    @register_jitable
    def pair(i, j, dx, dy, dz, r, I, J, P, acc):
        f = wall_term(j, i, -dx, -dy, -dz, r, J, I, P, (zero, zero, zero, zero, zero, zero, zero, zero, zero))
        v, m = J.m[j] / J.rho[j], J.m[j]
        return (acc[0] - v * f[2] - m * f[5], acc[1] - v * f[3] - m * f[6], acc[2] - v * f[4] - m * f[7])

    @register_jitable
    def store(i, I, P, acc):
        I.load[0, i] = acc[0]
        I.load[1, i] = acc[1]
        if dim == 3:
            I.load[2, i] = acc[2]

    return init, pair, store
