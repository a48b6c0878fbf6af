"""The WCSPH model, composed from the choices of the plug-in slots (``registry``).

``model.name`` is a preset: it picks each slot's default (``classic``: Becker & Teschner 2007
with Akinci et al. 2012 walls, density summation, Tait EOS, XSPH on the momentum; ``bi``: the
WCSPH-BI model of TNL-SPH, continuity density, Cole EOS, boundary elements, Molteni
diffusion). Any slot may be set in the case; ``slots.problems`` refuses the combinations the
physics does not allow.

Per derivative evaluation (the spec's initialize / interact / finalize):

1. density: summation pass (rho, then p, p/rho^2 and V = m/rho from the EOS), or, with
   continuity density, a map computing p, p/rho^2 and V from the advected rho;
2. the wall passes the selection declares (``physics.WallPass``): the wall particles' no-slip
   velocity and pressure, the consistent elements' p_b and rho_b from their fluid neighbours;
3. the fluid passes it declares (``physics.FluidPass``): CSPM's gradient correction L_i;
4. interaction: one pass over fluid and wall neighbours, the terms of every slot composed
   into one pair function (``physics.interaction`` gives the accumulator);
5. finalize (the pass's store): Drho/Dt = (-rho <div v> + delta h c0 D) / gamma,
   Dv/Dt = (f / rho + a) / gamma + g; gamma = 1 without the consistent wall model (and with
   CSPM, whose correction includes it).

After each time step the corrections run: DPC, XSPH on the positions, shifting, the CSPM
density re-initialisation, and the elastic bounce and NBVC-PST of boundary elements. Which
passes exist, what they write and the wall fields they need are the choices' declarations
(``Choice.passes``, ``Choice.wall_fields``); nothing here tests a choice's name or parameter.
"""
from collections import namedtuple

import numpy as np
from numba.extending import register_jitable

from ..physics import slots
from ..physics import AfterStepPass, Ctx, FluidPass, WallCorrection, WallPass, WallVolume, compose
from ..physics.loads import make_element_loads, make_particle_loads, measured
from ..physics.renormalization import make_shepard

# The views a pass sees: only the fields the case's terms can read. A view with unused arrays
# made the 2D WCSPH-BI interaction 5 % slower at 100 k particles and 11 % at 2.5 k (15 fields
# against 12, measured side by side), so there is one view class per combination of optional
# fields, each created at import under the name it is bound to (Numba's cache finds the
# types of its compiled loops by name).
_FLUID = "x v dvdt rho p pr vol m"
#: the fluid's fields beyond x, v, m, id: name -> (kind, the model flag that adds it or None for
#: every model). One table for what the set holds, what the views see and the stand-ins a
#: view gets for a field its case lacks; every one is scratch (written by each evaluation
#: before it is read) except rho of a continuity model. "matrix" is a (dim * dim,) field,
#: "symmetric" a symmetric matrix's dim (dim + 1) / 2 components (xx, xy, yy; xx, xy, xz, yy, yz, zz).
FLUID_FIELDS = {
    "dvdt": ("vector", None), "rho": ("scalar", None), "p": ("scalar", None), "pr": ("scalar", None),
    "vol": ("scalar", None), "drhodt": ("scalar", "continuity"), "shepard": ("scalar", "consistent"),
    "L": ("matrix", "corrected"), "corr": ("vector", "after_step"), "rho_corr": ("scalar", "after_step"),
    "c": ("scalar", "sound"), "tau_rho2": ("symmetric", "stress"),
}
#: the flags that add optional fields, in the order the view classes are named by
_FLAGS = ("continuity", "consistent", "corrected", "after_step", "sound", "stress")


def _fluid_view_name(flags):
    return "FluidView" + "".join("_" + opt for opt, on in zip(_FLAGS, flags) if on)


for _flags in __import__("itertools").product((False, True), repeat=len(_FLAGS)):
    _name = _fluid_view_name(_flags)
    _on = {f for f, on in zip(_FLAGS, _flags) if on}
    _fields = " ".join([_FLUID] + [k for k, (_, flag) in FLUID_FIELDS.items() if flag in _on] + ["cell start"])
    globals()[_name] = namedtuple(_name, _fields)
FluidView = globals()[_fluid_view_name((False,) * len(_FLAGS))]
ElementView = namedtuple("ElementView", "x v a n elementSize p rho cell start")
#: boundary elements as the load pass writes them (``measured``: the points it visits)
LoadView = namedtuple("LoadView", "x v a n elementSize load measured cell start")
#: boundary particles as the classic terms see them (Psi only), and with V = Psi/rho0, rho0
ParticleWallView = namedtuple("ParticleWallView", "x v psi cell start")
ParticleWallViewFull = namedtuple("ParticleWallViewFull", "x v psi vol rho cell start")
#: ... with the wall particles' own pressure (``wall_pressure = "adami"``)
ParticleWallViewPressure = namedtuple("ParticleWallViewPressure", "x v a psi vol rho p pr cell start")
#: ... each with the no-slip velocity the viscous terms read (``physics.viscosity``)
ParticleWallViewNoSlip = namedtuple("ParticleWallViewNoSlip", "x v v_ext psi cell start")
ParticleWallViewFullNoSlip = namedtuple("ParticleWallViewFullNoSlip", "x v v_ext psi vol rho cell start")
ParticleWallViewPressureNoSlip = namedtuple("ParticleWallViewPressureNoSlip",
                                            "x v v_ext a psi vol rho p pr cell start")
#: boundary particles as the no-slip velocity pass writes them
NoSlipWallView = namedtuple("NoSlipWallView", "x v v_ext cell start")
#: the wall views, smallest first: a case's is the first with every field its walls' terms and passes read
WALL_VIEWS = (ParticleWallView, ParticleWallViewFull, ParticleWallViewPressure, ParticleWallViewNoSlip,
              ParticleWallViewFullNoSlip, ParticleWallViewPressureNoSlip, ElementView)
#: the kinds of the wall sets' fields a view may lack in a case (a stand-in is passed)
WALL_FIELDS = {"n": "vector", "elementSize": "scalar", "psi": "scalar", "vol": "scalar", "p": "scalar",
               "rho": "scalar", "pr": "scalar"}
#: array dimensions of a field of each kind ((N,) scalars; (dim, N) vectors and matrices)
_NDIM = {"scalar": 1, "vector": 2, "matrix": 2, "symmetric": 2}


#: the views with extra fields that the model passes (``_with``), made when the module is
#: imported: a compiled loop's cache index names the classes of its arguments, and a process
#: that could not find one of them by name read the whole index as empty and wrote it anew,
#: dropping every other loop's entry (a floating case's load passes took the cache of every
#: other case's passes with them)
_EXTENDED_VIEWS = {}
for _view, _extra in [(v, ("measured",)) for v in (NoSlipWallView,) + WALL_VIEWS] + \
        [(v, ("load", "measured")) for v in WALL_VIEWS]:
    _fields = [f for f in _view._fields if f not in ("cell", "start")] + list(_extra) + ["cell", "start"]
    _cls = namedtuple(_view.__name__ + "".join(e.capitalize() for e in _extra), " ".join(_fields))
    globals()[_cls.__name__] = _cls  # found by name, as every view class
    _EXTENDED_VIEWS[_view, _extra] = _cls


def _with(view, *extra):
    """``view`` with the fields ``extra`` before the cell list (one class per view and extra,
    made at import: ``_EXTENDED_VIEWS``)."""
    return _EXTENDED_VIEWS[view, extra]


def _stores(ctx, eos, continuity, consistent, needs_pr, corrected, sound):
    zero, one, dim = ctx.zero, ctx.dtype(1), ctx.dim
    needs_c = sound is not None

    @register_jitable
    def state(i, I, P, rho):
        p = eos(rho, P)
        I.p[i] = p
        if needs_c:  # the sound speed, for Monaghan's Pi (once per particle, not per pair)
            I.c[i] = sound(rho, P)
        if needs_pr:  # p/rho^2, for the m_j (p_i/rho_i^2 + p_j/rho_j^2) forms only
            I.pr[i] = p / (rho * rho)
        I.vol[i] = I.m[i] / rho

    @register_jitable
    def initialize(i, I, P):
        state(i, I, P, I.rho[i])

    @register_jitable
    def init_scalar(i, I, P):
        return zero

    @register_jitable
    def store_density(i, I, P, acc):
        I.rho[i] = acc
        state(i, I, P, acc)

    @register_jitable
    def init9(i, I, P):
        return (zero, zero, zero, zero, zero, zero, zero, zero, zero)

    @register_jitable
    def finalize(i, I, P, acc):
        # the Shepard factor divides the consistent scheme's sums; the CSPM-corrected sums are
        # the derivatives themselves
        gam = acc[8] if consistent and not corrected else one
        if consistent:
            I.shepard[i] = acc[8]
        rho = I.rho[i]
        if continuity:
            I.drhodt[i] = (P.delta_hc0 * acc[1] - rho * acc[0]) / gam
        k = one / (rho * gam)
        ka = k * rho
        I.dvdt[0, i] = acc[2] * k + acc[5] * ka + P.gx
        I.dvdt[1, i] = acc[3] * k + acc[6] * ka + P.gy
        if dim == 3:
            I.dvdt[2, i] = acc[4] * k + acc[7] * ka + P.gz

    return dict(initialize=initialize, state=state, init_scalar=init_scalar, store_density=store_density,
                init9=init9, finalize=finalize)


#: the fields ``refresh_fn`` of a particle reads and writes: a view of the spare arrays the
#: predictor run in a pass's loop writes p and V to (``spare_view``)
RefreshView = namedtuple("RefreshView", "p pr vol m c")


class WCSPH:

    def __init__(self, case, backend):
        self.case = case
        self.backend = backend
        self.dim = dim = case["dim"]
        self.dtype = dtype = np.dtype(case["precision"]).type
        self.m = m = case["model"]
        self.name = m["name"]
        self.sel = sel = slots.selection(m)
        self._stepped = [c for c in sel.values() if c.step_values is not None]
        wall = sel["walls"]
        self.boundary, self.consistent = wall.boundary, wall.consistent
        # what the selected choices declare they need (``Choice.implies``)
        self.implies = implied = frozenset().union(*(c.implies for c in sel.values()))
        self.continuity = "continuity" in implied
        self.corrected = "corrected" in implied
        self.default_integrator = "symplectic_verlet" if self.continuity else "symplectic_euler"
        ctx = self.ctx = Ctx.create(dtype, dim, m["kernel"])
        self.q = q = slots.Quantities(m, case["physics"], dim, case["dp"], 0.0, 0.0, 0.0, {}, None,
                                        boundary=self.boundary, conservative=not self.consistent,
                                        corrected=self.corrected, continuity=self.continuity)
        eos_p, q.eos_density, q.sound = sel["eos"].build(ctx, q)
        self.needs_c = "sound" in implied
        # the fields of a neighbour a decomposed run refreshes on its ghosts (``parallel.Halo``):
        # the state before an evaluation; with what the EOS store writes from it (p, V and, for
        # the choices that read them, p/rho^2 and c) after the density pass and after a step
        eos = ("p", "vol") + (("pr",) if "pr" in implied else ()) + (("c",) if self.needs_c else ())
        self.exchanged = {"state": ("x", "v", "rho"), "density": ("rho",) + eos, "settled": ("x", "v", "rho") + eos}
        s = _stores(ctx, eos_p, self.continuity, self.consistent, "pr" in implied,
                    self.corrected, q.sound if self.needs_c else None)
        from ..case.geometry import periodic_axes

        self.periodic = periodic_axes(case)

        def mk(*args, **kw):
            return backend.make_pass(*args, periodic=self.periodic, **kw)

        #: p and V of particle i from a density, fn(i, I, P, rho) with I the ``refresh_view``:
        #: what ``refresh`` does, for an integrator that runs it in its own map's loop with the
        #: density it wrote (``Integrator.fuse_refresh``); None with summation density
        self.refresh_fn = s["state"] if self.continuity else None
        if self.continuity:
            self.initialize_map = backend.make_map(s["initialize"])
            self.density_pass = None
        else:
            fluid_term, wall_term = sel["density"].build(ctx, q)
            self.density_pass = mk(dim, dtype, s["init_scalar"], fluid_term, s["store_density"], pair2=wall_term)
        # the passes the choices declare beyond their terms, in slot order
        declared = [p for c in sel.values() if c.passes is not None for p in c.passes(ctx, q)]
        q.noslip = any(isinstance(p, WallPass) and p.velocity for p in declared)
        volume = [p for p in declared if isinstance(p, WallVolume)]
        self.volume_pass = mk(dim, dtype, volume[0].init, volume[0].pair, volume[0].store) if volume else None
        self.wall_passes = [(p, mk(dim, dtype, p.init, p.pair, p.store)) for p in declared if isinstance(p, WallPass)]
        self.fluid_passes = [(p, mk(dim, dtype, p.init, p.fluid, p.store, pair2=p.wall))
                             for p in declared if isinstance(p, FluidPass)]
        corrections = [p for p in declared if isinstance(p, WallCorrection)]
        self.wall_corrections = [mk(dim, dtype, p.init, p.pair, p.store) for p in corrections]
        #: the wall corrections as one (init, pair, store) of fluid particle i over the walls,
        #: for an integrator that runs them in its last map's loop (``Integrator.fuse_tail``)
        self.correction_walk = ((corrections[0].init, corrections[0].pair, corrections[0].store)
                                if len(corrections) == 1 else None)
        # the load passes visit only the points of the bodies whose loads are asked for (the
        # walls' ``measured``): the tank's walls are most of the points in a floating-body case
        self.load_pass = None
        if self.boundary == "elements":  # the fluid's load on each element (body forces)
            shear = sel["viscous"].build(ctx, q).wall if sel["viscous"].build is not None else []
            self.load_pass = mk(dim, dtype, *make_element_loads(
                ctx, compose(*shear) if shear else None, shared=self.consistent and sel["viscous"].nu is None),
                keep=measured)
        #: the wall passes the boundary particles' loads read, run again before them on those points
        self.load_wall_passes = [(p, mk(dim, dtype, p.init, p.pair, p.store, keep=measured))
                                 for p in declared if isinstance(p, WallPass) and p.loads]

        fluid, walls = [], []
        for slot in ("density", "pressure", "diffusive", "viscous", "xsph"):
            c = sel[slot]
            if c.build is None or (slot == "density" and not self.continuity):
                continue
            t = c.build(ctx, q)
            if isinstance(t, AfterStepPass):
                continue
            fluid += t.fluid
            walls += t.wall
        if self.consistent:
            fluid.append(make_shepard(ctx))
        # the heaviest pass. Its terms evaluated for every candidate, without a branch
        # (backends/walk.py), measured against the branch in one process: 2D WCSPH-BI dam
        # break 1.27 times faster at 2.5 k and 100 k; 2D hydrostatic (Fourtakas' pow per pair)
        # 0.96; 3D (4.5 candidates per neighbour) 0.90; the light classic force pass 0.47.
        # Hence for 2D boundary elements only.
        self.interaction = mk(dim, dtype, s["init9"], compose(*fluid), s["finalize"],
                              pair2=compose(*walls) if walls else None,
                              branchless=dim == 2 and self.boundary == "elements")
        self._interaction_parts = (dim, dtype, s["init9"], compose(*fluid), s["finalize"],
                                   compose(*walls) if walls else None, dim == 2 and self.boundary == "elements")
        #: the fields ``refresh_fn`` writes
        self.refreshed = ("p", "vol") + (("pr",) if "pr" in implied else ()) + (("c",) if self.needs_c else ())

        if self.boundary == "particles" and walls:  # the fluid's load on each wall particle
            self.load_pass = mk(dim, dtype, *make_particle_loads(ctx, compose(*walls)), keep=measured)

        # the passes after each step, in this order
        self.after_step_passes = []
        for slot in ("collision", "xsph", "shifting"):
            c = sel[slot]
            if c.build is not None:
                t = c.build(ctx, q)
                if isinstance(t, AfterStepPass):
                    self.after_step_passes.append(t)
        self.after_step_passes += [p for p in declared if isinstance(p, AfterStepPass)]
        self.after_step_runs = [
            (c, mk(dim, dtype, c.init, c.fluid, c.store, pair2=c.wall), backend.make_map(c.apply))
            for c in self.after_step_passes]
        self._placeholders = {}
        # the flags that add fluid fields: the selection's ``implies`` and two the model knows
        on = set(implied) | ({"consistent"} if self.consistent else set()) | (
            {"after_step"} if self.after_step_passes else set())
        self._flags = tuple(flag in on for flag in _FLAGS)
        self.fluid_view = globals()[_fluid_view_name(self._flags)]
        # the smallest wall view with what the walls' terms and passes read
        reads = {f for flag, fields in wall.wall_reads.items() if flag is None or flag in implied for f in fields}
        for p, _ in self.wall_passes:
            reads |= set(p.reads) | {f for f, _ in p.writes}
        self.wall_view = next(v for v in WALL_VIEWS if reads <= set(v._fields))
        # the wall views of the load passes of boundary particles: the points they visit, and
        # the load they write
        self.noslip_load_view = _with(NoSlipWallView, "measured")
        self.plain_load_view = _with(self.wall_view, "measured")
        self.wall_load_view = _with(self.wall_view, "load", "measured")

    # ------------------------------------------------------------------ set-up
    def fluid_fields(self):
        """(name, kind, scratch) of the fields this selection needs (``FLUID_FIELDS``):
        scratch when every evaluation writes the field before reading it (sorting skips those)."""
        on = {f for f, v in zip(_FLAGS, self._flags) if v}
        kinds = {"matrix": (self.dim * self.dim,), "symmetric": (self.dim * (self.dim + 1) // 2,)}
        return [(name, kinds.get(kind, kind), not (name == "rho" and self.continuity))
                for name, (kind, flag) in FLUID_FIELDS.items() if flag is None or flag in on]

    def wall_fields(self):
        """(name, kind) of the wall set's fields: the wall model's and its passes' outputs."""
        fields = dict(self.sel["walls"].wall_fields)
        for p, _ in self.wall_passes:
            fields.update(p.writes)
        return list(fields.items())

    def particle_mass(self, dp, h, rho0, kernel_w):
        """``mass`` when given; else the mass that makes the summation density of the initial
        lattice exactly rho0 (summation density), or rho0 dp^dim (the lattice cell's mass)."""
        if self.m["mass"]:
            return self.m["mass"]
        if not self.continuity:
            from ..case.geometry import lattice_density_sum

            return rho0 / lattice_density_sum(kernel_w, self.dim, dp, h)
        return rho0 * dp ** self.dim

    def initial_mass(self, mass, cell, rho, rho0):
        """Each fluid particle's mass at the start: ``mass`` times its lattice cell (over
        dp^dim), and with a continuity density and wall particles times rho / rho0, so that
        its volume m / rho is its cell: a column started at its hydrostatic density on the
        plain lattice had volumes 0.5-1 % short of the cells they stand in, the classic
        model's pressure gradient (no Shepard sum renormalizes it) as much weaker, and it
        settled onto a floor pressure 1.7 % above its weight (docs/accuracy.md §4). Boundary
        elements keep rho0 times the cell: the consistent scheme divides by the Shepard sum,
        which makes up for the short volumes (with rho / rho0 its floor read 2 % low); the
        conservative scheme is not renormalized either, and not measured with it."""
        if self.continuity and self.boundary == "particles":
            return mass * cell * (rho / rho0)
        return mass * cell

    def kinematic_viscosity(self):
        """The largest kinematic viscosity a selected choice declares (``Choice.nu``), for
        the viscous time-step limit; 0 when none does."""
        return max([c.nu(self.q) for c in self.sel.values() if c.nu is not None], default=0.0)

    def initial_density(self, x, tops, P, gravity, pressure=None):
        """Continuity density: rho = EOS^-1(p0 + p) with p the block's ``pressure`` where
        given (``pressure``, NaN elsewhere), else hydrostatic under each fluid block's top
        (``tops``), p = rho0 |g| depth, so that a column starts in equilibrium (DualSPHysics
        and TNL-SPH cases do the same). Summation density: rho0 (the first evaluation sums it)."""
        if not self.continuity:
            return np.full(x.shape[1], float(P.rho0))
        g = abs(float(gravity[-1]))
        dpres = float(P.rho0) * g * np.maximum(tops - x[-1], 0.0)
        if pressure is not None:
            dpres = np.where(np.isnan(pressure), dpres, pressure)
        Pd = P._replace(**{f: float(v) for f, v in P._asdict().items()})  # in double precision
        return np.asarray(self.q.eos_density(Pd.p0 + dpres, Pd), dtype=float)

    def params(self, kernel, rho0, c0, h, gravity, dt, kernel_numpy):
        q = self.q
        q.kernel, q.c0, q.rho0, q.h, q.kernel_numpy = kernel, c0, rho0, h, kernel_numpy
        return slots.make_params(self.dtype, q, self.sel, gravity, dt)

    def stepped_values(self):
        """(P field, c, power) of each field of P made from the step's size (``slots.step_value``)."""
        return slots.stepped_values(self.q, self._stepped)

    def update(self, P, dt, gravity, vmax=0.0):
        return slots.update_params(P, self.dtype, self.q, self._stepped, dt, gravity, vmax)

    def initialize(self, fluid, walls, P, G):
        """Boundary particles' pseudo-masses Psi (then V = Psi/rho0, rho = rho0).
        ``akinci``: rho0 / sum_l W_kl over wall neighbours, Akinci et al. (2012) eq. 5, made for
        a single layer of wall particles; on the fluid-facing layer of a thick wall it counts
        only half a neighbourhood and doubles Psi. ``lattice``: the same formula with the sum
        over the full lattice the wall is sampled on, Psi = the fluid particle mass times the
        wall lattice's cell over dp^dim (as set up, ``walls["psi"]``), which makes a wall of full
        kernel depth act like fluid at rest (the dummy-particle limit, Adami et al. 2012)."""
        if not walls.n or self.boundary != "particles":
            return
        be = self.backend
        if self.volume_pass is not None:
            w = self.view(walls, self.wall_view)
            self.volume_pass(w, w, w, P, G)
        psi = be.to_host(walls["psi"])
        rho0 = float(P.rho0)
        walls["vol"] = be.to_device((psi / rho0).astype(self.dtype))
        walls["rho"] = be.to_device(np.full(walls.n, rho0, dtype=self.dtype))

    def view(self, pset, cls):
        """``cls`` over ``pset``, with a stand-in for each field the set lacks (never read)."""
        a = pset.arrays
        ph = self._placeholders
        return cls._make([a[f] if f in a else (ph.get(f) or self._placeholder(f)) for f in cls._fields])

    def _placeholder(self, name):
        if name not in self._placeholders:
            kind = FLUID_FIELDS[name][0] if name in FLUID_FIELDS else WALL_FIELDS[name]
            shape = (1,) * _NDIM[kind]
            self._placeholders[name] = self.backend.to_device(np.zeros(shape, dtype=self.dtype))
        return self._placeholders[name]

    # ------------------------------------------------------------------ per evaluation
    def interaction_then(self, then):
        """The interaction pass with then(i, I, S, R, P) in its loop after each particle's
        derivatives (``backend.make_pass``'s ``then``; I the pass's fluid view), called with
        S and R after the pass's own arguments (``derivatives``'s ``then``)."""
        dim, dtype, init, pair1, finish, pair2, branchless = self._interaction_parts
        return self.backend.make_pass(dim, dtype, init, pair1, finish, pair2=pair2, branchless=branchless,
                                      periodic=self.periodic, then=then, parts=self.interaction)

    def add_spares(self, fluid):
        """A spare array beside each field ``refresh_fn`` writes (``spare_view``); returns the
        (field, spare) pairs."""
        for k in self.refreshed:
            fluid.add(k + "_spare", "scalar", self.dtype, self.backend, scratch=True)
        return tuple((k, k + "_spare") for k in self.refreshed)

    def spare_view(self, fluid):
        """A ``RefreshView`` (what ``refresh_fn`` reads and writes) with the spare arrays of
        ``add_spares`` for the fields it writes."""
        a = fluid.arrays

        def pick(k):
            if k in self.refreshed:
                return a[k + "_spare"]
            return a[k] if k in a else self._placeholder(k)

        return RefreshView(*[pick(k) for k in RefreshView._fields])

    def derivatives(self, fluid, walls, P, G, halo=None, refreshed=False, then=None):
        """Drho/Dt (continuity) or rho (summation), and Dv/Dt of every fluid particle.
        ``halo`` (a decomposed run's ``parallel.Halo``): after each pass whose output a later
        pass reads of a neighbour, the ghosts' (or the walls') copies of it are refreshed
        from their owners, so that one kernel support of ghosts is enough. ``refreshed``:
        p and V are already those of the current rho (the integrator's last map ran
        ``refresh_fn``), so the evaluation starts with the walls. ``then`` = (interaction,
        S, R): that interaction pass (``interaction_then``) instead of the model's, with its
        map's views."""
        f = self.view(fluid, self.fluid_view)
        w = self.view(walls, self.wall_view)
        if self.continuity:
            if not refreshed:
                self.initialize_map(f, P)
        else:
            self.density_pass(f, f, w, P, G)
            if halo is not None:
                halo.fluid(self.exchanged["density"])
        if walls.n:
            w = self._wall_passes(walls, f, w, P, G, halo)
        for p, run in self.fluid_passes:
            run(f, f, w, P, G)
            if halo is not None and p.writes:  # a later pass reads it of a neighbour
                halo.fluid(p.writes)
        if then is None:
            self.interaction(f, f, w, P, G)
        else:
            run, S, R = then
            run(f, f, w, P, G, S, R)

    def _wall_passes(self, walls, f, w, P, G, halo=None, loads=False):
        """The declared wall passes (with ``loads``, those the loads read, over the measured
        points only), each refreshing what it wrote on a decomposed run's walls; returns the
        wall view ``w`` (a no-slip pass's velocity is its ``v_ext``, which only the viscous
        terms read)."""
        noslip = self.noslip_load_view if loads else NoSlipWallView
        plain = self.view(walls, self.plain_load_view) if loads else w
        for p, run in (self.load_wall_passes if loads else self.wall_passes):
            run(self.view(walls, noslip) if p.velocity else plain, f, f, P, G)
            if halo is not None:
                halo.walls(walls, tuple(name for name, _ in p.writes))
        return w

    def wall_loads(self, fluid, walls, P, G):
        """The fluid's load on each measured wall point (``physics.loads``; the walls'
        ``measured``, the others left as they were), written to the walls' ``load`` (dim, n).
        Boundary elements: p_b n_b S_b plus the viscous wall term's reaction; boundary
        particles: the reaction of the wall terms (their no-slip velocity and pressure from
        the current fluid first, on the measured points). p must be current (``refresh``); the
        consistent scheme's Shepard factor is the last evaluation's."""
        if "load" not in walls.arrays:
            walls.add("load", "vector", self.dtype, self.backend, scratch=True)
        if walls.n:
            f = self.view(fluid, self.fluid_view)
            if self.boundary == "elements":
                self.load_pass(self.view(walls, LoadView), f, f, P, G)
            else:
                w = self._wall_passes(walls, f, self.view(walls, self.wall_load_view), P, G, loads=True)
                self.load_pass(w, f, f, P, G)
        return walls["load"]

    def refresh_view(self, fluid):
        """The view ``refresh_fn`` takes of ``fluid``."""
        return self.view(fluid, self.fluid_view)

    def refresh(self, fluid, P):
        """p and V from the current density (continuity density: the last evaluation may have
        been at an integrator's intermediate stage; summation: those of the step's pass)."""
        if self.continuity:
            self.initialize_map(self.view(fluid, self.fluid_view), P)

    def after_step_due(self, step):
        """Whether a pass before the wall corrections runs after time step number ``step``."""
        return any(step % t[0].every == 0 for t in self.after_step_runs)

    def tail_views(self, fluid, walls):
        """The views the wall corrections run on in an integrator's tail (fluid, walls)."""
        return self.view(fluid, self.fluid_view), self.view(walls, self.wall_view)

    def after_step(self, fluid, walls, P, G, step=1, settle=None, corrected=False):
        """The passes after time step number ``step``: DPC, XSPH on the positions, shifting,
        CSPM density re-initialisation (every N steps), then the elastic bounce and NBVC-PST
        of boundary elements (``wall_corrections``; ``corrected``: the integrator's last map
        ran them). ``settle()``, when given, replaces the refresh of p and V before each pass
        (a decomposed run also refreshes its ghosts there)."""
        due = self.after_step_runs and [t for t in self.after_step_runs if step % t[0].every == 0]
        if due:
            w = self.view(walls, self.wall_view)
            for c, run, apply in due:
                if settle is None:
                    self.refresh(fluid, P)  # p and V of the state the pass starts from
                else:
                    settle()
                f = self.view(fluid, self.fluid_view)
                run(f, f, w, P, G)
                apply(f, P)
        if self.wall_corrections and walls.n and not corrected:
            w = self.view(walls, self.wall_view)
            for run in self.wall_corrections:
                run(self.view(fluid, self.fluid_view), w, w, P, G)
