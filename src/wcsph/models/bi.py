"""WCSPH-BI: WCSPH with Shepard renormalization and boundary-integral walls (the WCSPH-BI
model of TNL-SPH; spec ``wcsph-bi_tnl-sph.md``).

Walls are boundary elements (centre x, unit normal n out of the fluid, size S). The four
schemes are two plug-in choices:

* ``BCType``: ``BIConservative_numeric`` (boundary integrals in conservative form, no
  renormalization) or ``BIConsistent_numeric`` (asymmetric/symmetric boundary forms, Shepard
  factor gamma, wall pressure interpolated from the fluid);
* ``ViscousTerm``: ``None`` (inviscid) or a viscous term (the spec's viscous schemes use
  ``PhysicalViscosity_MGVT``; ``PhysicalViscosity_MVT`` and ``ArtificialViscosity`` plug in the
  same way).

Per derivative evaluation (the spec's initialize / interact / finalize):

1. initialize (a map over fluid particles): p_i from the EOS, V_i = m_i / rho_i;
2. interact, boundary part (consistent schemes only): each element gets p_b and rho_b from its
   fluid neighbours;
3. interact, fluid part: one pass over fluid and element neighbours accumulating
   <div v>, the diffusive term, the force density and gamma (``physics.interaction``);
4. finalize (the pass's store): Drho/Dt = (-rho <div v> + delta h c0 D) / gamma,
   Dv/Dt = (-<grad p> + viscous force) / (rho gamma) + g; gamma = 1 for conservative schemes.

After each time step the wall corrections (elastic bounce, NBVC-PST) run as one more pass.
The integrator advances x, v and rho (continuity density); the model never sees it.
"""
from collections import namedtuple

import numpy as np
from numba.extending import register_jitable

from ..physics import Ctx, compose
from ..physics.continuity import make_boundary_divergence, make_divergence
from ..physics.diffusion import DIFFUSIVE_TERMS, make_fourtakas
from ..physics.eos import COLE
from ..physics.pressure import make_bi_boundary_pressure, make_bi_pressure
from ..physics.renormalization import make_boundary_interpolation, make_shepard
from ..physics.viscosity import VISCOUS_TERMS, make_boundary_viscosity
from ..physics.wall_corrections import make_wall_corrections

FluidView = namedtuple("FluidView", "x v dvdt rho drhodt p vol m gamma cell start")
ElementView = namedtuple("ElementView", "x v n elementSize p rho cell start")
Params = namedtuple("Params", "rc2 h_inv w_norm g_norm rho0 rho0_inv c2 p0 eos_b gamma gamma_inv "
                                "gx gy gz dt delta_hc0 eps_h2 visc wall_visc r_box2 min_dist elastic")


def _stores(ctx, pressure, consistent):
    zero, one, dim = ctx.zero, ctx.dtype(1), ctx.dim

    @register_jitable
    def initialize(i, I, P):
        rho = I.rho[i]
        I.p[i] = pressure(rho, P)
        I.vol[i] = I.m[i] / rho

    @register_jitable
    def init3(i, I, P):
        return (zero, zero, zero)

    @register_jitable
    def init6(i, I, P):
        return (zero, zero, zero, zero, zero, zero)

    @register_jitable
    def store_boundary(i, I, P, acc):
        if acc[2] > zero:
            I.p[i] = acc[0] / acc[2]
            I.rho[i] = acc[1] / acc[2]
        else:
            I.p[i] = P.p0
            I.rho[i] = P.rho0

    @register_jitable
    def finalize(i, I, P, acc):
        gam = acc[5] if consistent else one
        I.gamma[i] = gam
        rho = I.rho[i]
        I.drhodt[i] = (P.delta_hc0 * acc[1] - rho * acc[0]) / gam
        k = one / (rho * gam)
        I.dvdt[0, i] = acc[2] * k + P.gx
        I.dvdt[1, i] = acc[3] * k + P.gy
        if dim == 3:
            I.dvdt[2, i] = acc[4] * k + P.gz

    @register_jitable
    def init_correction(i, I, P):
        vz = I.v[2, i] if dim == 3 else zero
        return (I.v[0, i], I.v[1, i], vz, zero, zero, zero)

    @register_jitable
    def store_correction(i, I, P, acc):
        I.v[0, i] = acc[0]
        I.v[1, i] = acc[1]
        I.x[0, i] += acc[3]
        I.x[1, i] += acc[4]
        if dim == 3:
            I.v[2, i] = acc[2]
            I.x[2, i] += acc[5]

    return initialize, init3, init6, store_boundary, finalize, init_correction, store_correction


class WCSPHBI:
    name = "bi"
    fluid_view = FluidView
    wall_view = ElementView
    continuity = True  # rho is a state the integrator advances
    default_integrator = "symplectic_verlet"

    def __init__(self, case, backend):
        self.case = case
        self.backend = backend
        self.dim = dim = case["dim"]
        self.dtype = np.dtype(case["precision"]).type
        m = self.m = case["model"]
        self.consistent = m["BCType"] == "BIConsistent_numeric"
        ctx = Ctx.create(self.dtype, dim, m["kernel"])
        self.eos_pressure, self.eos_density = COLE[m["EOS"]](self.dtype)
        initialize, init3, init6, store_b, finalize, init_c, store_c = _stores(
            ctx, self.eos_pressure, self.consistent)
        mk = backend.make_pass
        self.initialize_map = backend.make_map(initialize)
        if self.consistent:
            self.boundary_pass = mk(dim, self.dtype, init3, make_boundary_interpolation(ctx), store_b)

        fluid = [make_divergence(ctx), make_bi_pressure(ctx)]
        walls = [make_boundary_divergence(ctx, not self.consistent),
                 make_bi_boundary_pressure(ctx, not self.consistent)]
        if m["DiffusiveTerm"] == "FourtakasDiffusiveTerm":
            fluid.append(make_fourtakas(ctx, self.eos_density))
        elif m["DiffusiveTerm"] != "None":
            fluid.append(DIFFUSIVE_TERMS[m["DiffusiveTerm"]](ctx))
        if m["ViscousTerm"] != "None":
            fluid.append(VISCOUS_TERMS[m["ViscousTerm"]](ctx))
            walls.append(make_boundary_viscosity(ctx, m["ViscousTerm"] == "ArtificialViscosity"))
        if self.consistent:
            fluid.append(make_shepard(ctx))
        # the heaviest pass. Its terms evaluated for every candidate, without a branch
        # (backends/walk.py), measured against the branch in one process: 2D dam break
        # 1.27 times faster at 2.5 k and 100 k; 2D hydrostatic (Fourtakas' pow per pair)
        # 0.96; 3D (4.5 candidates per neighbour) 0.90. Hence in 2D only.
        self.interaction = mk(dim, self.dtype, init6, compose(*fluid), finalize, pair2=compose(*walls),
                              branchless=dim == 2)

        bounce, shift = m["enableElasticBounce"], m["enableShifting"]
        self.correction = None
        if bounce or shift:
            term = make_wall_corrections(ctx, bounce, m["elasticBounce"] == "epsilon", shift)
            self.correction = mk(dim, self.dtype, init_c, term, store_c)

    # ------------------------------------------------------------------ set-up
    def fluid_fields(self):
        """(name, kind, scratch) as for the classic model; rho is a state here."""
        return [("dvdt", "vector", True), ("rho", "scalar", False), ("drhodt", "scalar", True),
                ("p", "scalar", True), ("vol", "scalar", True), ("gamma", "scalar", True)]

    def wall_fields(self):
        return [("p", "scalar"), ("rho", "scalar")]

    def particle_mass(self, dp, h, rho0, kernel_w):
        """``mass`` when given, else rho0 dp^dim (the lattice cell's mass)."""
        return self.m["mass"] or rho0 * dp ** self.dim

    def kinematic_viscosity(self, rho0):
        return self.m["dynamicViscosity"] / rho0 if self.m["ViscousTerm"].startswith("Physical") else 0.0

    def sound_speed_b(self, c0, rho0, gamma):
        """B of the Cole EOS: ``coefB``, else c0^2 rho0 / gamma."""
        return self.m["coefB"] or c0 * c0 * rho0 / gamma

    def initial_density(self, x, blocks, rho0, c0, gamma, gravity):
        """Hydrostatic density under each fluid block's top, rho = EOS^-1(p0 + rho0 |g| depth),
        so that a column starts in equilibrium (DualSPHysics and TNL-SPH cases do the same);
        ``blocks`` gives each particle's block top."""
        g = abs(float(gravity[-1]))
        dpres = rho0 * g * np.maximum(blocks - x[-1], 0.0)
        if self.m["EOS"] == "LinearizedColeEquationOfState":
            return rho0 + dpres / (c0 * c0)
        b = self.sound_speed_b(c0, rho0, gamma)
        return rho0 * (1.0 + dpres / b) ** (1.0 / gamma)

    def params(self, kernel, rho0, gamma, c0, gravity, dt):
        d, m, dim = self.dtype, self.m, self.dim
        g = list(gravity) + [0.0] * (3 - len(gravity))
        h = 1.0 / kernel["h_inv"]
        dp = self.case["dp"]
        mu, alpha = m["dynamicViscosity"], m["alpha"]
        visc = {"None": 0.0, "ArtificialViscosity": alpha * h * c0, "PhysicalViscosity_MVT": 2.0 * mu,
                "PhysicalViscosity_MGVT": 2.0 * (dim + 2) * mu}[m["ViscousTerm"]]
        delta = m["delta"] if m["DiffusiveTerm"] != "None" else 0.0
        return Params(
            rc2=d(kernel["rc"] ** 2), h_inv=d(kernel["h_inv"]), w_norm=d(kernel["w_norm"]),
            g_norm=d(kernel["g_norm"]), rho0=d(rho0), rho0_inv=d(1.0 / rho0), c2=d(c0 * c0),
            p0=d(self.case["physics"]["p0"]), eos_b=d(self.sound_speed_b(c0, rho0, gamma)), gamma=d(gamma),
            gamma_inv=d(1.0 / gamma), gx=d(g[0]), gy=d(g[1]), gz=d(g[2]), dt=d(dt),
            delta_hc0=d(delta * h * c0), eps_h2=d(m["eps"] * h * h), visc=d(visc),
            wall_visc=d(visc * m["scaleBVTCoef"]), r_box2=d((m["r_boxFactor"] * dp) ** 2),
            min_dist=d(m["minimalDistanceFactor"] * dp), elastic=d(m["elasticFactor"]))

    def update(self, P, dt, gravity):
        d = self.dtype
        g = list(gravity) + [0.0] * (3 - len(gravity))
        return P._replace(dt=d(dt), gx=d(g[0]), gy=d(g[1]), gz=d(g[2]))

    def initialize(self, fluid, walls, P, G, lattice_mass):
        """Nothing to precompute: element normals and sizes come with the geometry."""

    # ------------------------------------------------------------------ per evaluation
    def derivatives(self, fluid, walls, P, G):
        """Drho/Dt and Dv/Dt of every fluid particle at the current state."""
        f = fluid.view(FluidView)
        w = walls.view(ElementView)
        self.initialize_map(f, P)
        if self.consistent and walls.n:
            self.boundary_pass(w, f, f, P, G)
        self.interaction(f, f, w, P, G)

    def refresh(self, fluid, P):
        """p and V from the current density (for output: the last evaluation may have been at
        an integrator's intermediate stage)."""
        self.initialize_map(fluid.view(FluidView), P)

    def correct(self, fluid, walls, P, G):
        """Elastic bounce and NBVC-PST after a time step."""
        if self.correction is not None and walls.n:
            self.correction(fluid.view(FluidView), walls.view(ElementView), walls.view(ElementView), P, G)
