"""Classic WCSPH of Becker & Teschner (2007) with the boundary particles of Akinci et al.
(2012), as described in the SPlisHSPlasH documentation:

1. wall volumes (once): Psi_k = rho0 / sum_l W_kl over wall neighbours l;
2. density pass: rho_i = sum_j m_j W_ij + sum_k Psi_k W_ik, then p_i from the Tait EOS;
3. force pass: symmetric pressure force, mirrored-pressure wall force, XSPH, gravity;
4. the integrator (symplectic Euler) advances v and x.
"""
from collections import namedtuple

import numpy as np
from numba.extending import register_jitable

from ..physics import Ctx, compose
from ..physics.density import make_akinci_density, make_akinci_volume, make_summation
from ..physics.eos import make_tait
from ..physics.pressure import make_akinci_pressure, make_symmetric_pressure
from ..physics.viscosity import make_xsph, make_xsph_wall

FluidView = namedtuple("FluidView", "x v dvdt rho p pr vol m cell start")
WallView = namedtuple("WallView", "x v psi cell start")
Params = namedtuple("Params", "rc2 h_inv w_norm g_norm rho0 rho0_inv eos_b gamma gx gy gz dt xsph_dt wall_xsph_dt")


def _stores(ctx, eos):
    """init/finish functions of the three passes."""
    zero, dim = ctx.zero, ctx.dim

    @register_jitable
    def init_scalar(i, I, P):
        return zero

    @register_jitable
    def init_vector(i, I, P):
        return (zero, zero, zero)

    @register_jitable
    def store_psi(i, I, P, acc):
        I.psi[i] = P.rho0 / acc

    @register_jitable
    def store_density(i, I, P, acc):
        p = eos(acc, P)
        I.rho[i] = acc
        I.p[i] = p
        I.pr[i] = p / (acc * acc)
        I.vol[i] = I.m[i] / acc

    @register_jitable
    def store_acceleration(i, I, P, acc):
        I.dvdt[0, i] = acc[0] + P.gx
        I.dvdt[1, i] = acc[1] + P.gy
        if dim == 3:
            I.dvdt[2, i] = acc[2] + P.gz

    return init_scalar, init_vector, store_psi, store_density, store_acceleration


class ClassicWCSPH:
    name = "classic"
    fluid_view = FluidView
    wall_view = WallView
    continuity = False  # density by summation: the integrator advances x and v only
    default_integrator = "symplectic_euler"

    def __init__(self, case, backend):
        self.case = case
        self.backend = backend
        self.dim = case["dim"]
        self.dtype = np.dtype(case["precision"]).type
        m = case["model"]
        ctx = Ctx.create(self.dtype, self.dim, m["kernel"])
        eos = make_tait(self.dtype, m["clamp_negative_pressure"])
        init_s, init_v, store_psi, store_rho, store_a = _stores(ctx, eos)
        mk = backend.make_pass
        self.volume_pass = mk(self.dim, self.dtype, init_s, make_akinci_volume(ctx), store_psi)
        self.density_pass = mk(self.dim, self.dtype, init_s, make_summation(ctx), store_rho,
                               pair2=make_akinci_density(ctx))
        fluid_terms = [make_symmetric_pressure(ctx)]
        wall_terms = [make_akinci_pressure(ctx)]
        if m["xsph"] > 0:
            fluid_terms.append(make_xsph(ctx))
        if m["wall_xsph"] > 0:
            wall_terms.append(make_xsph_wall(ctx))
        self.force_pass = mk(self.dim, self.dtype, init_v, compose(*fluid_terms), store_a,
                             pair2=compose(*wall_terms))

    def fluid_fields(self):
        """Per-particle fields the model needs beyond x, v: (name, 'scalar'|'vector', scratch),
        scratch when every evaluation writes the field before reading it."""
        return [("dvdt", "vector", True), ("rho", "scalar", True), ("p", "scalar", True), ("pr", "scalar", True),
                ("vol", "scalar", True), ("m", "scalar", False)]

    def wall_fields(self):
        return [("psi", "scalar")]

    def particle_mass(self, dp, h, rho0, kernel_w):
        """The mass that makes the summation density of the initial lattice exactly rho0."""
        from ..geometry import lattice_density_sum

        return rho0 / lattice_density_sum(kernel_w, self.dim, dp, h)

    def kinematic_viscosity(self, rho0):
        return 0.0

    def initial_density(self, x, tops, rho0, c0, gamma, gravity):
        return np.full(x.shape[1], rho0)  # replaced by the summation at the first evaluation

    def refresh(self, fluid, P):
        """p is that of the step's density pass."""

    def correct(self, fluid, walls, P, G):
        """No wall corrections: the wall particles' pressure keeps the fluid out."""

    def params(self, kernel, rho0, gamma, c0, gravity, dt):
        d, m = self.dtype, self.case["model"]
        g = list(gravity) + [0.0] * (3 - len(gravity))
        return Params(
            rc2=d(kernel["rc"] ** 2), h_inv=d(kernel["h_inv"]), w_norm=d(kernel["w_norm"]),
            g_norm=d(kernel["g_norm"]), rho0=d(rho0), rho0_inv=d(1.0 / rho0),
            eos_b=d(c0 * c0 * rho0 / gamma), gamma=d(gamma), gx=d(g[0]), gy=d(g[1]), gz=d(g[2]),
            dt=d(dt), xsph_dt=d(m["xsph"] / dt), wall_xsph_dt=d(m["wall_xsph"] / dt))

    def update(self, P, dt, gravity):
        """P for a step of size ``dt`` under body force ``gravity``."""
        d, m = self.dtype, self.case["model"]
        g = list(gravity) + [0.0] * (3 - len(gravity))
        return P._replace(dt=d(dt), xsph_dt=d(m["xsph"] / dt), wall_xsph_dt=d(m["wall_xsph"] / dt),
                          gx=d(g[0]), gy=d(g[1]), gz=d(g[2]))

    def initialize(self, fluid, walls, P, G, lattice_mass):
        """Wall pseudo-masses Psi. ``akinci``: rho0 / sum_l W_kl over wall neighbours, Akinci
        et al. (2012) eq. 5, made for a single layer of wall particles; on the fluid-facing
        layer of a thick wall it counts only half a neighbourhood and doubles Psi.
        ``lattice``: the same formula with the sum over the full lattice the wall is sampled
        on, Psi = rho0 V0 = the fluid particle mass, which makes a wall of full kernel depth
        act like fluid at rest (the dummy-particle limit, Adami et al. 2012)."""
        if not walls.n:
            return
        if self.case["model"]["wall_volume"] == "akinci":
            w = walls.view(WallView)
            self.volume_pass(w, w, w, P, G)
        else:
            walls["psi"] = self.backend.to_device(np.full(walls.n, lattice_mass, dtype=self.dtype))

    def derivatives(self, fluid, walls, P, G):
        """rho, p and a of every fluid particle at the current state."""
        f = fluid.view(FluidView)
        w = walls.view(WallView)
        self.density_pass(f, f, w, P, G)
        self.force_pass(f, f, w, P, G)
