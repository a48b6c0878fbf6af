"""The simulation driver: set-up from a case, the time loop, checks and output."""
import json
import math
import signal
import threading
import time
from pathlib import Path

import numpy as np

from . import geometry, parallel
from .backends import get_backend
from .config import CaseError
from .grid import Grid
from .integrators import INTEGRATORS, SPEC_SCHEMES, IntegrationError, StateView
from .io import probes, vtk
from .kernels import SUPPORT, kernel_numpy, kernel_params
from .models import get_model
from .motion import Bodies
from .open_boundary import OpenBoundaries
from .particles import ParticleSet
from .progress import Progress


#: the layout of checkpoint.npz; a checkpoint of another version is refused
CHECKPOINT_VERSION = 2


def case_fingerprint(case):
    """A hash of what determines a run's state: the case without its end time, step limit,
    output settings and source path (those may change on a restart)."""
    import hashlib

    keep = {k: v for k, v in case.items() if not k.startswith("_") and k != "output"}
    keep["time"] = {k: v for k, v in case["time"].items() if k not in ("end", "max_steps")}
    return hashlib.sha256(json.dumps(keep, sort_keys=True, default=str).encode()).hexdigest()


class SimulationError(RuntimeError):
    """The run stopped on a non-physical state (NaN, runaway velocity)."""


class OutputError(RuntimeError):
    """An output file could not be written (disk full, directory gone, permissions)."""


class RunInterrupted(RuntimeError):
    """The run was stopped by Ctrl-C or SIGTERM; its state at the last full step is written."""


class _StopRequest:
    """While active, Ctrl-C (SIGINT) and SIGTERM only ask the time loop to stop after the
    current step, so that the state written is a whole step's; a second Ctrl-C stops at once.
    Outside the main thread (where Python allows no signal handlers) it does nothing."""

    NAMES = {signal.SIGINT: "Ctrl-C (SIGINT)", signal.SIGTERM: "SIGTERM"}

    def __init__(self):
        self.signal = None
        self._previous = {}

    def _handle(self, signum, frame):
        if self.signal is not None and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self.signal = self.NAMES.get(signum, f"signal {signum}")

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for sig in self.NAMES:
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc):
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        return False


class Simulation:
    """A case set up on a backend, ready to step. ``case`` is a validated case dict.
    ``comm``: the MPI communicator to share the case over (``parallel``); by default the
    world of ``mpiexec``/``srun`` when started by one with several processes, else none."""

    def __init__(self, case, backend=None, comm="world"):
        t_setup = time.perf_counter()
        self.case = case
        self.par = None  # the decomposition over MPI ranks (``parallel``), when there is one
        try:
            comm = parallel.world() if comm == "world" else comm
        except parallel.ParallelError as e:
            raise CaseError(str(e)) from None
        if comm is not None and comm.Get_size() > 1 and (backend or case["backend"]) == "cuda":
            parallel.select_gpu(comm)  # before the backend makes a CUDA context
        self.dim = dim = case["dim"]
        self.dtype = dtype = np.dtype(case["precision"]).type
        self.backend = be = get_backend(backend or case["backend"])
        self.dp = dp = case["dp"]
        m = case["model"]
        self.h = h = geometry.smoothing_length(case)
        geometry.check_size(case)
        fluid0, wall0, lo, hi = geometry.build(case)
        self.open = None
        particle_kind = None
        if case["open_boundary"]:  # the buffers' particles join the fluid set, kind > 0
            self.open = OpenBoundaries(case, dp, SUPPORT * geometry.smoothing_length(case))
            bx, bv, bp, bkind = self.open.initial_particles(geometry.lattice)
            out = ~np.all((bx >= lo[:, None]) & (bx <= hi[:, None]), axis=0)
            if out.any():
                raise CaseError(f"{case['_source']}: open_boundary: {int(out.sum())} buffer particles lie outside "
                                f"the domain {list(lo)} .. {list(hi)}")
            particle_kind = np.concatenate([np.zeros(fluid0["x"].shape[1], dtype=np.int64), bkind])
            fluid0 = {"x": np.concatenate([fluid0["x"], bx], axis=1), "v": np.concatenate([fluid0["v"], bv], axis=1),
                      "top": np.concatenate([fluid0["top"], np.full(bx.shape[1], bx[-1].max() + 0.5 * dp)]),
                      "p": np.concatenate([fluid0["p"], bp])}
        fluid_x, fluid_v = fluid0["x"], fluid0["v"]
        self.domain = (lo, hi)
        rc = SUPPORT * h
        if m["searchRadius"] > 0:
            if m["searchRadius"] < rc * (1 - 1e-9):
                raise CaseError(f"{case['_source']}: model.searchRadius: {m['searchRadius']} is smaller than "
                                f"the kernel support 2h = {rc:g}")
            rc = m["searchRadius"]
        try:
            self.grid = Grid.covering(lo, hi, rc, periodic=geometry.periodic_axes(case)[:dim])
        except ValueError as e:
            raise CaseError(f"{case['_source']}: domain.periodic: {e}") from None
        self.G = self.grid.view()

        ph = case["physics"]
        self.rho0 = ph["rho0"]
        self.gravity = np.asarray(ph["gravity"], dtype=float)
        # Becker & Teschner's stiffness kappa is c0^2 of p = kappa rho0/gamma ((rho/rho0)^gamma - 1)
        self.c0 = (math.sqrt(ph["kappa"]) if ph["kappa"] > 0 else ph["speed_of_sound"]) \
            or self._default_sound_speed(fluid_x, fluid_v)
        w_np, _ = kernel_numpy(m["kernel"], dim, h)
        self.warnings = list(case.get("_warnings", ()))  # settings that make results doubtful

        self.model = model = get_model(m["name"])(case, be)
        self.mass = model.particle_mass(dp, h, self.rho0, w_np)
        scheme = case["time"]["integrator"] or model.default_integrator
        scheme = SPEC_SCHEMES.get(scheme, scheme)
        self.integrator = INTEGRATORS[scheme](be, dim, model.continuity, dtype, settings=dict(
            case["time"], adaptive=case["time"]["dt"] <= 0))
        tc = case["time"]
        self.cfl = tc["cfl"] or self.integrator.default_cfl()
        stable = self.integrator.stable_cfl
        if tc["cfl"] and tc["dt"] <= 0 and model.continuity and stable and tc["cfl"] > stable:
            self.warnings.append(f"time.cfl = {tc['cfl']:g} is past the largest stable value measured for "
                                 f"{scheme} ({stable:g}, benchmarks/integrators.py); leave time.cfl out for its "
                                 f"default ({self.integrator.default_cfl():g})")
        if h < dp * (1 - 1e-9):
            self.warnings.append(f"h = {h:g} m is smaller than dp = {dp:g} m: a particle has almost no "
                                 "neighbours and the SPH sums are meaningless")
        kp = dict(kernel_params(m["kernel"], dim, h), rc=rc)
        self.P = model.params(kp, self.rho0, self.c0, h, self.gravity, 1.0, w_np)

        n = fluid_x.shape[1]
        rho = model.initial_density(fluid_x, fluid0["top"], self.P, self.gravity, fluid0["p"])
        ids = np.arange(n, dtype=np.int64)  # follows the particle
        if comm is not None and comm.Get_size() > 1:  # every rank built the case: keep one's own
            if self.open is not None:
                raise CaseError(f"{case['_source']}: open_boundary: open boundaries run on one process only "
                                "(buffers create and remove particles); run the case without mpiexec")
            pc = case["parallel"]
            try:
                occupied = np.concatenate([fluid_x, wall0["x"]], axis=1)  # the box with work in it
                self.par = parallel.Decomposition(comm, self.grid, be, pc["axis"],
                                                  pc["balance_threshold"], pc["balance_interval"],
                                                  extent=np.ptp(occupied, axis=1), balance=pc["balance"])
            except ValueError as e:
                raise CaseError(f"{case['_source']}: parallel.axis: {e}") from None
            mine = self.par.split(fluid_x)
            fluid_x, fluid_v, rho, ids = fluid_x[:, mine], fluid_v[:, mine], rho[mine], ids[mine]
            n = fluid_x.shape[1]
        self.fluid = ParticleSet("fluid", dim, {"x": be.to_device(fluid_x.astype(dtype)),
                                               "v": be.to_device(fluid_v.astype(dtype))})
        self.halo = parallel.Halo(self.par, self.fluid) if self.par is not None else None
        for name, kind, scratch in list(model.fluid_fields()) + list(self.integrator.fields):
            self.fluid.add(name, kind, dtype, be, scratch=scratch)
        self.fluid["rho"] = be.to_device(rho.astype(dtype))
        self.fluid["m"] = be.to_device(np.full(n, self.mass, dtype=dtype))
        self.fluid["id"] = be.to_device(ids)
        if particle_kind is not None:
            self.fluid["kind"] = be.to_device(particle_kind)  # 0 fluid, 1 + k the buffer of open_boundary[k]
        self._placeholders = {"k": be.to_device(np.zeros((1, 1, 1), dtype=dtype)),
                              "w": be.to_device(np.zeros(1, dtype=dtype))}
        body = wall0.pop("body")
        self.bodies = Bodies(geometry.wall_sources(case), dim, wall0["x"], wall0.get("n"), body,
                             Path(case["_source"]).parent)
        self.walls = ParticleSet("walls", dim, {k: be.to_device(a.astype(dtype)) for k, a in wall0.items()})
        self.walls.add("v", "vector", dtype, be)
        self.walls["body"] = be.to_device(body)  # the body each wall point belongs to
        if self.bodies.moving:  # the placement at t = 0 each moving wall point is carried from
            self.walls["x0"] = be.to_device(wall0["x"].astype(dtype))
            if "n" in wall0:
                self.walls["n0"] = be.to_device(wall0["n"].astype(dtype))
        for name, kind in model.wall_fields():
            self.walls.add(name, kind, dtype, be)
        self.place_walls(0.0)
        be.sort(self.walls, self.grid)
        be.wrap(self.fluid, self.grid)
        if self.par is None:
            be.sort(self.fluid, self.grid)
        else:  # ghosts from the other ranks, then sorted with one's own
            self.par.redistribute(self.fluid)
        model.initialize(self.fluid, self.walls, self.P, self.G, self.mass)
        self.probes = probes.PointProbes(self)

        self.t = 0.0
        self.steps = 0
        self.evaluations = 0  # derivative evaluations (integrator stages, midpoint iterations)
        self.dropped = 0
        self.vmax = float(np.max(np.linalg.norm(fluid_v, axis=0))) if n else 0.0
        self.amax = float(np.linalg.norm(self.gravity))
        self._resumed_output = None  # the output series to continue, after a restart
        self.setup_time = time.perf_counter() - t_setup  # compiles (or loads) the loops

    def _default_sound_speed(self, x, v):
        """c0 = 10 max(sqrt(|g| H), |v0|): density varies by about 1 % (Monaghan 1994)."""
        g = float(np.linalg.norm(self.case["physics"]["gravity"]))
        height = float(x[-1].max() - x[-1].min()) + self.dp
        vmax = float(np.max(np.linalg.norm(v, axis=0))) if v.size else 0.0
        c0 = 10.0 * max(math.sqrt(g * height), vmax)
        if c0 == 0:
            raise CaseError(f"{self.case['_source']}: physics.speed_of_sound: must be set when "
                            "there is neither gravity nor an initial velocity")
        return c0

    # ------------------------------------------------------------------------------ stepping
    def gravity_factor(self, t):
        """Gravity switched on smoothly over ``physics.gravity_ramp_time`` t_d, Adami, Hu &
        Adams (2012): g(t) = g (sin((t/t_d - 1/2) pi) + 1) / 2, so that a column at rest starts
        without the pressure wave a sudden load excites."""
        td = self.case["physics"]["gravity_ramp_time"]
        if td <= 0 or t >= td:
            return 1.0
        return 0.5 * (math.sin((t / td - 0.5) * math.pi) + 1.0)

    def stable_time_step(self):
        """The least of the CFL (sound speed plus flow speed), force (Monaghan 1992) and
        viscous (Morris et al. 1997) conditions: dt = min(cfl h/(c0 + |v|max),
        force_cfl sqrt(h/|a|max), 0.125 h^2/nu)."""
        tc = self.case["time"]
        dt = self.cfl * self.h / (self.c0 + self.vmax)
        if self.amax > 0:
            dt = min(dt, tc["force_cfl"] * math.sqrt(self.h / self.amax))
        nu = self.model.kinematic_viscosity()
        if nu > 0:
            dt = min(dt, 0.125 * self.h * self.h / nu)
        return dt

    def time_step(self):
        """Constant ``time.dt``, else the stability conditions (``stable_time_step``), which
        an adaptive integrator may lower; ``dtInit`` for the first step when given. Falling
        below ``dtMin`` stops the run."""
        tc = self.case["time"]
        if tc["dt"] > 0:
            return tc["dt"]
        if self.steps == 0 and tc["dtInit"] > 0:
            return tc["dtInit"]
        dt = self.integrator.propose(self.stable_time_step())
        if dt < tc["dtMin"]:
            raise SimulationError(f"time step {dt:.3g} s fell below time.dtMin = {tc['dtMin']:.3g} s at "
                                  f"t = {self.t:.6g} s (|v|max = {self.vmax:.3g} m/s, |a|max = {self.amax:.3g} m/s^2)")
        return dt

    def state(self, w=None):
        """The fluid as the integrators see it (``StateView``), with ``w`` the scheme's
        coefficients; stand-ins (of the right kind) for the fields this model or scheme
        lacks, which the scheme then never reads."""
        a = self.fluid.arrays
        x, v, rho = a["x"], a["v"], a["rho"]
        return StateView(x, v, a["dvdt"], rho, a.get("drhodt", rho), a["p"], a["m"], a.get("x_n", x), a.get("v_n", v),
                         a.get("rho_n", rho), a.get("dv_t", v), a.get("drho_t", rho),
                         a.get("k", self._placeholders["k"]), self._placeholders["w"] if w is None else w)

    def params_for(self, dt):
        """The model parameters for a step of size ``dt`` from the current time."""
        return self.model.update(self.P, dt, self.gravity * self.gravity_factor(self.t), self.vmax)

    def evaluate(self, P):
        """The model's derivatives at the current state (called by the integrator); a
        decomposed run first refreshes its ghosts' state from their owners."""
        self.evaluations += 1
        if self.par is not None:
            self.par.update(self.fluid, parallel.STATE)
        self.model.derivatives(self.fluid, self.walls, P, self.G, self.halo)

    def reduce(self, fn, state, P):
        """A reduction map of the integrator (``backend.make_reduce``): (sum, sum, max) over
        the particles, over every rank's own in a decomposed run."""
        if self.par is None:
            return fn(state, P)
        a, b, c = fn(state, P, self.fluid["owned"])
        s = self.par.sum([a, b])
        return float(s[0]), float(s[1]), float(self.par.max([c])[0])

    def settle(self):
        """p and V from the current density (``model.refresh``) and, in a decomposed run,
        the ghosts' state and those fields from their owners: what corrections, probes and
        body loads read of a neighbour after a step."""
        self.model.refresh(self.fluid, self.P)
        if self.par is not None:
            self.par.update(self.fluid, parallel.SETTLED)

    def n_fluid(self):
        """Fluid particles in the case (over every rank)."""
        if self.par is None:
            return self.fluid.n
        return int(self.par.sum([self.par.n_owned])[0])

    def owned_host(self, *names):
        """Host copies of the fluid's ``names``, of this rank's own particles only."""
        arrays = self.host(self.fluid, *names)
        if self.par is None:
            return arrays
        mine = self.backend.to_host(self.fluid["owned"]) != 0
        return [a[..., mine] for a in arrays]

    def place_walls(self, t):
        """Moving walls to their position, normal and velocity at time t, then wrapped and
        sorted (``motion.Bodies``); nothing when every wall is fixed. Called at the end of
        each step: a step's stages see the walls where they are at its start."""
        if not self.bodies.moving:
            return
        be, w = self.backend, self.walls
        x0, body = self.host(w, "x0", "body")
        n0 = be.to_host(w["n0"]) if "n0" in w.arrays else None
        x, n, v = self.bodies.place(t, x0.astype(float), None if n0 is None else n0.astype(float), body)
        w["x"] = be.to_device(x.astype(self.dtype))
        w["v"] = be.to_device(v.astype(self.dtype))
        if n is not None:
            w["n"] = be.to_device(n.astype(self.dtype))
        be.wrap(w, self.grid)
        lost = be.sort(w, self.grid)
        if lost:
            raise SimulationError(f"{lost} wall points of a moving body left the domain at t = {t:.6g} s; "
                                  "enlarge [domain] or change the motion")

    def body_loads(self):
        """Force and torque of the fluid on each named body: {NAME_fx, NAME_fy[, NAME_fz],
        NAME_torque (2D) or NAME_tx, NAME_ty, NAME_tz (3D)}, the torque about the body's
        centre.

        Boundary elements: the sum of the body's element loads (``physics.loads``: the wall's
        own pressure p_b n_b S_b and the reaction of the viscous wall term), the torque with
        each element's lever arm. Boundary particles: minus the sum of m_i (a_i - a_i without
        the body) over the fluid, the derivatives evaluated once with every wall and once
        without the body's walls at the current state (every field they write is restored
        after); the torque with each fluid particle's lever arm (an O(h) approximation)."""
        named = [b for b, name in enumerate(self.bodies.names) if name]
        if not named:
            return {}
        if self.model.boundary == "elements":
            loads = self._element_body_loads(named)
        else:
            loads = self._particle_body_loads(named)
        out = {}
        for b, (force, torque) in zip(named, loads):
            if self.par is not None:
                force, torque = np.split(self.par.sum(np.concatenate([force, np.ravel(torque)])), [self.dim])
            name = self.bodies.names[b]
            for a, c in enumerate("xyz"[: self.dim]):
                out[f"{name}_f{c}"] = float(force[a])
            if self.dim == 2:
                out[f"{name}_torque"] = float(np.ravel(torque)[0])
            else:
                for a, c in enumerate("xyz"):
                    out[f"{name}_t{c}"] = float(torque[a])
        return out

    def _element_body_loads(self, named):
        be, w, par = self.backend, self.walls, self.par
        self.settle()
        load = be.to_host(self.model.wall_loads(self.fluid, w, self.P, self.G)).astype(float)
        x, body = self.host(w, "x", "body")
        x = x.astype(float)
        if par is not None:  # each element from the rank whose slab holds it (all its neighbours are there)
            load = load * (par.owner(par.column(x)) == par.rank)
        out = []
        for b in named:
            sel = body == b
            f = load[:, sel]
            r = x[:, sel] - self.bodies.reference(b, self.t)[:, None]
            torque = [np.sum(r[0] * f[1] - r[1] * f[0])] if self.dim == 2 else np.cross(r.T, f.T).sum(axis=0)
            out.append((f.sum(axis=1), np.asarray(torque)))
        return out

    def _particle_body_loads(self, named):
        be, fl, par = self.backend, self.fluid, self.par
        if par is not None:
            par.update(fl, parallel.STATE)
        saved = {k: be.to_host(fl[k]).copy() for k in fl.per_particle() if k in fl.scratch or k == "rho"}
        self.model.derivatives(fl, self.walls, self.P, self.G, self.halo)
        mine = be.to_host(fl["owned"]) != 0 if par is not None else slice(None)
        x, m, a_all = (a.astype(float)[..., mine] for a in self.host(fl, "x", "m", "dvdt"))
        out = []
        host = {k: be.to_host(self.walls[k]) for k in self.walls.per_particle() if k != "cell"}
        for b in named:
            keep = host["body"] != b
            rest = ParticleSet("walls", self.dim, {k: be.to_device(np.ascontiguousarray(a[..., keep]))
                                                    for k, a in host.items()})
            be.sort(rest, self.grid)
            self.model.derivatives(fl, rest, self.P, self.G, self.halo)
            f = m * (a_all - be.to_host(fl["dvdt"]).astype(float)[..., mine])  # on the fluid, from the body
            r = x - self.bodies.reference(b, self.t)[:, None]
            torque = [-np.sum(r[0] * f[1] - r[1] * f[0])] if self.dim == 2 else -np.cross(r.T, f.T).sum(axis=0)
            out.append((-f.sum(axis=1), np.asarray(torque)))
        for k, a in saved.items():
            fl[k] = be.to_device(a)
        return out

    def body_columns(self):
        cols = []
        for name in self.bodies.names:
            if name:
                cols += [f"{name}_f{c}" for c in "xyz"[: self.dim]]
                cols += [f"{name}_torque"] if self.dim == 2 else [f"{name}_t{c}" for c in "xyz"]
        return cols

    def step(self, dt):
        """One time step: sort by cell (once: the neighbour cells of the step's first state
        serve its later stages too, which moves particles by far less than a cell), the
        integrator's stages, then the model's wall corrections. An adaptive integrator may
        take a smaller step than ``dt``; returns the step taken."""
        be, par = self.backend, self.par
        if par is None:
            self.dropped += be.sort(self.fluid, self.grid)
        else:  # ghosts dropped, particles migrated (and the cuts moved), new ghosts, sorted
            self.dropped += par.redistribute(self.fluid)
        self.P = self.params_for(dt)
        if self.open is not None:
            self.open.before(self)
        try:
            dt = self.integrator.step(self, self.P)
        except IntegrationError as e:
            raise SimulationError(f"{e} at t = {self.t:.6g} s (step {self.steps})") from None
        if dt != float(self.P.dt):
            self.P = self.params_for(dt)
        self.model.correct(self.fluid, self.walls, self.P, self.G, self.steps + 1,
                           settle=self.settle if par is not None else None)
        if self.open is not None:  # buffers prescribed; particles enter, leave, are created
            self.open.after(self, dt)
        be.wrap(self.fluid, self.grid)  # a particle that left through a periodic side re-enters
        self.t += dt
        self.steps += 1
        self.place_walls(self.t)  # moving walls where they are at the new time (output, next step)
        if par is None:
            n = self.fluid.n
            vmax2, amax2, bad = be.check(self.fluid)
        else:  # over every rank's own particles: every rank takes the same step next
            vmax2, amax2, bad = be.check(self.fluid, self.fluid["owned"])
            vmax2, amax2 = par.max([vmax2, amax2])
            bad, n = (int(c) for c in par.sum([bad, par.n_owned]))
        if n == 0:
            raise SimulationError(f"every fluid particle has left the domain by t = {self.t:.6g} s "
                                  f"(step {self.steps}); enlarge [domain] or close the tank")
        self.vmax, self.amax = math.sqrt(vmax2), math.sqrt(amax2)
        if bad:
            raise SimulationError(f"{bad} fluid particles have a non-finite position, velocity or "
                                  f"acceleration at t = {self.t:.6g} s (step {self.steps}): the run blew up")
        if self.vmax > self.c0:
            raise SimulationError(f"runaway velocity {self.vmax:.3g} m/s exceeds the speed of sound "
                                  f"{self.c0:.3g} m/s at t = {self.t:.6g} s (step {self.steps})")
        return dt

    def host(self, pset, *names):
        return [self.backend.to_host(pset[k]) for k in names]

    # ------------------------------------------------------------------------------ restarts
    def save_checkpoint(self, path, output_state=None):
        """Everything a restart needs to continue bit for bit, as one ``.npz`` (written
        atomically): every per-particle array of the fluid, the time, the step count, the
        speeds the next time step is taken from, the integrator's carried scalars (Verlet's
        step count, RK45's next step, the midpoint's primed guess) and the output series."""
        from . import __version__

        names = [k for k in self.fluid.per_particle() if k != "owned"]
        arrays = dict(zip(names, self.owned_host(*names)))
        dropped = self.dropped
        if self.par is not None:  # one file of every rank's own particles: restarts on any count
            arrays = self.par.gather(arrays)
            dropped = int(self.par.sum([dropped])[0])
            if self.par.rank != 0:
                return
        meta = {"format": "wcsph checkpoint", "version": CHECKPOINT_VERSION, "wcsph": __version__,
                "case": {k: v for k, v in self.case.items() if not k.startswith("_")},
                "fingerprint": case_fingerprint(self.case), "t": self.t, "steps": self.steps,
                "evaluations": self.evaluations, "dropped": dropped, "vmax": self.vmax, "amax": self.amax,
                "n": int(arrays["x"].shape[1]), "integrator": self.integrator.carried_state(), "output": output_state,
                "open_boundary": self.open.carried_state() if self.open is not None else None}
        arrays = {f"fluid.{k}": a for k, a in arrays.items()}
        with vtk.atomic(path) as tmp:
            with open(tmp, "wb") as f:
                np.savez(f, meta=np.array(json.dumps(meta)), **arrays)

    @staticmethod
    def read_checkpoint(path):
        """(meta, arrays) of a checkpoint; a CaseError when it is not one this version reads."""
        path = Path(path)
        if path.is_dir():
            path = path / "checkpoint.npz"
        try:
            with np.load(path, allow_pickle=False) as data:
                meta = json.loads(str(data["meta"]))
                arrays = {k.split(".", 1)[1]: data[k] for k in data.files if k.startswith("fluid.")}
        except FileNotFoundError:
            raise CaseError(f"{path}: no checkpoint there (runs write one at their end, at a clean stop "
                            "and every output.checkpoint_interval)") from None
        except (OSError, ValueError, KeyError) as e:
            raise CaseError(f"{path}: not a readable wcsph checkpoint ({e})") from None
        if meta.get("format") != "wcsph checkpoint" or meta.get("version") != CHECKPOINT_VERSION:
            raise CaseError(f"{path}: checkpoint format version {meta.get('version')!r}; this wcsph reads "
                            f"version {CHECKPOINT_VERSION}")
        return meta, arrays

    def restore(self, meta, arrays, source="checkpoint"):
        """Continue from a checkpoint of the same case (``time.end``, ``time.max_steps`` and
        ``[output]`` may differ)."""
        if meta["fingerprint"] != case_fingerprint(self.case):
            raise CaseError(f"{source}: the checkpoint is from another case or other settings "
                            f"(case {meta['case'].get('name')!r}); restart it with the case it was written by")
        be = self.backend
        for k in self.fluid.per_particle():
            if k not in arrays and k != "owned":
                raise CaseError(f"{source}: the checkpoint lacks the fluid field {k!r}")
        self.fluid.arrays.pop("owned", None)
        if self.par is not None:  # any number of ranks: each keeps its own of the whole
            mine = self.par.split(arrays["x"])
            arrays = {k: a[..., mine] for k, a in arrays.items()}
        self.fluid.n = int(arrays["x"].shape[1])
        for k, a in arrays.items():
            self.fluid[k] = be.to_device(np.ascontiguousarray(a))
        for k in [k for k in self.fluid.arrays if k.startswith("_")]:
            del self.fluid.arrays[k]  # the sort's spare arrays, sized for the old count
        self.t, self.steps, self.evaluations = meta["t"], meta["steps"], meta["evaluations"]
        self.dropped, self.vmax, self.amax = meta["dropped"], meta["vmax"], meta["amax"]
        if self.par is not None:
            self.par.redistribute(self.fluid)
            if self.par.rank != 0:
                self.dropped = 0  # counted once, on rank 0
        self.integrator.restore(meta["integrator"])
        if self.open is not None:
            self.open.restore(meta["open_boundary"])
        self.place_walls(self.t)
        self._resumed_output = meta["output"]

    # ------------------------------------------------------------------------------ running
    def run(self, output=None, end_time=None, progress=None):
        """Step to ``end_time`` (default the case's); write output to directory ``output``
        (nothing if None). Returns the run summary (also written to ``run.json``). A file
        that cannot be written (a full disk, a removed directory) stops the run with an
        ``OutputError``; every file written before is whole (they are written atomically)."""
        try:
            return self._run(output, end_time, progress)
        except OSError as e:
            ckpt = Path(output) / "checkpoint.npz" if output is not None else None
            last = (f"; the last checkpoint ({ckpt}) is intact" if ckpt is not None and ckpt.exists() else "")
            raise OutputError(f"cannot write to {output}: {e.strerror or e}; the files written before "
                              f"are whole{last}") from None

    def _run(self, output, end_time, progress):
        case = self.case
        end = end_time if end_time is not None else case["time"]["end"]
        oc = case["output"]
        interval = oc["interval"] or end / 20
        out = Path(output) if output is not None else None
        writer = Output(self, out, oc, self._resumed_output) if out is not None else None
        max_steps = case["time"]["max_steps"]
        show = oc["progress"] if progress is None else progress
        par = self.par
        show = show and (par is None or par.rank == 0)

        t_start = time.perf_counter()
        resumed = self._resumed_output or {}
        next_out = resumed.get("next_out", self.t)
        ckpt_every = oc["checkpoint_interval"]
        next_ckpt = self.t + ckpt_every
        probe_every = oc["probe_interval"]  # 0: a probes.csv row with every frame
        next_probe = resumed.get("next_probe", self.t)
        slack = 1e-9 * end  # round-off in the summed time; not worth a step of its own
        io_time = 0.0
        compile_time = None
        t_loop = None
        status, message = "completed", ""
        stop = _StopRequest()
        try:
            with Progress(end, enabled=show) as bar, stop:
                while True:
                    written = False
                    if writer is not None and self.t >= next_out - slack:
                        t0 = time.perf_counter()
                        writer.write(sample=not probe_every)
                        io_time += time.perf_counter() - t0
                        next_out += interval
                        written = True
                    if writer is not None and probe_every and self.t >= next_probe - slack:
                        t0 = time.perf_counter()
                        writer.sample()
                        io_time += time.perf_counter() - t0
                        next_probe += probe_every
                    if writer is not None and ckpt_every > 0 and self.t >= next_ckpt - slack:
                        writer.checkpoint(next_out, next_probe)
                        next_ckpt += ckpt_every
                    stopping = stop.signal is not None
                    if par is not None and par.any(stopping):  # every rank stops at the same step
                        stopping = True
                        stop.signal = stop.signal or "a signal to another rank"
                    if stopping:
                        status = "interrupted"
                        message = (f"stopped by {stop.signal} at t = {self.t:.6g} s (step {self.steps})")
                        if writer is not None:
                            if not written:
                                writer.write()
                            message += f"; state written to {writer.last_good}"
                        break
                    if self.t >= end - slack or (max_steps and self.steps >= max_steps):
                        break
                    dt = min(self.time_step(), end - self.t)
                    t0 = time.perf_counter()
                    self.step(dt)
                    if writer is not None:
                        writer.log_step()
                    if compile_time is None:
                        compile_time = time.perf_counter() - t0
                        t_loop = time.perf_counter()
                        steps0 = self.steps
                        io0 = io_time
                    elapsed = time.perf_counter() - t_loop
                    rate = (self.steps - steps0) / max(elapsed - (io_time - io0), 1e-9)
                    bar.update(self.t, self.steps, rate)
        except SimulationError as e:
            status, message = "failed", str(e)
            if writer is not None:
                writer.write(failed=True)
                message += f"; last good output: {writer.last_good}"
        if writer is not None and status != "failed":
            writer.checkpoint(next_out, next_probe)  # a clean stop or the end: the run can be continued
        wall = time.perf_counter() - t_start
        n_fluid = self.n_fluid()
        dropped = self.dropped if par is None else int(par.sum([self.dropped])[0])
        stepping = (time.perf_counter() - t_loop - (io_time - io0)) if t_loop else 0.0
        timed_steps = self.steps - steps0 if t_loop else 0
        summary = {
            "case": case["name"], "status": status, "message": message, "model": case["model"]["name"],
            "backend": self.backend.name, "precision": case["precision"], "dim": self.dim, "dp": self.dp,
            "h": self.h, "speed_of_sound": self.c0, "particle_mass": self.mass,
            "n_fluid": n_fluid, "n_boundary": self.walls.n, "dropped": dropped,
            "steps": self.steps, "evaluations": self.evaluations, "end_time": self.t, "wall_time_s": wall,
            "compile_time_s": self.setup_time + (compile_time or 0.0), "io_time_s": io_time, "stepping_time_s": stepping,
            "particle_steps_per_s": n_fluid * timed_steps / stepping if stepping > 0 else 0.0,
        }
        if par is not None:  # the decomposition: ranks, cuts, the exchanges' share of the time
            share = par.sum([par.exchange_time, par.n_owned]) / par.size
            summary["parallel"] = {
                "ranks": par.size, "axis": "xyz"[par.axis], "cuts": [int(c) for c in par.cuts],
                "rebalances": par.rebalances, "imbalance": par.imbalance,
                "migrated": int(par.sum([par.migrated])[0]),
                "exchange_time_s_mean": float(share[0]), "exchange_time_s_max": float(par.max([par.exchange_time])[0]),
                "particles_per_rank_max": int(par.max([par.n_owned])[0]), "particles_per_rank_mean": float(share[1])}
        if self.open is not None:  # particles created at inlets, removed at outlets
            summary["open_boundary"] = self.open.summary()
        if writer is not None:
            writer.close(summary)
        if status == "failed":
            raise SimulationError(message)
        if status == "interrupted":
            raise RunInterrupted(message)
        return summary


class Output:
    """VTK series, probes.csv and run.json in one directory. In a decomposed run each rank
    writes its piece of every frame (``fluid_NNNN_pR.vtu``) and rank 0 the ``.pvtu`` that
    joins them, the series and the tables; a file one rank cannot write stops every rank."""

    def __init__(self, sim, out, oc, resumed=None):
        self.sim, self.out, self.oc = sim, out, oc
        self.par = sim.par
        self.root = self.par is None or self.par.rank == 0
        resumed = resumed or {}
        self.entries = [tuple(e) for e in resumed.get("entries", [])]
        self.count = resumed.get("count", 0)
        self.iter_max = resumed.get("iter_max", 0)
        self.last_good = "(none written)"
        cols = ["time", "step", "dt", "n_fluid", "kinetic_energy", "potential_energy"]
        if oc["surge_front"]:
            cols.append("surge_front")
        cols += sim.probes.columns() + sim.body_columns()
        self.stats = sim.integrator.columns()  # per-step figures of the scheme (midpoint, RK45)
        cols += self.stats + (["midpoint_iterations_max"] if "midpoint_iterations" in self.stats else [])
        self.probes = self.steps_log = None

        def start():
            out.mkdir(parents=True, exist_ok=True)
            # frames of an earlier run in the same directory (or, on a restart, written after
            # the checkpoint) would sit beside the series without being listed in it
            keep = {_frame(e[2]) for e in self.entries}
            for old in [*out.glob("fluid_[0-9]*.vtu"), *out.glob("fluid_[0-9]*.pvtu"), *out.glob("walls_[0-9]*.vtu"),
                        *out.glob("fluid_failed*.vtu"), *out.glob("fluid_failed.pvtu"), *out.glob(".*.tmp[0-9]*")]:
                if _frame(old.name) not in keep or old.name.startswith("."):
                    old.unlink()
            upto = sim.steps if resumed else None  # a restart keeps the rows up to its checkpoint
            self.probes = probes.ProbeWriter(out / "probes.csv", cols, keep_steps=upto)
            self.steps_log = probes.ProbeWriter(out / "steps.csv", ["step", "time", "dt"] + self.stats,
                                                keep_steps=upto) if self.stats else None
            if oc["vtk"] and sim.walls.n and not sim.bodies.moving:
                self._write_walls("walls.vtu")

        self._root(start)

    def _agreed(self, fn, here=True):
        """``fn()`` where ``here``; an OSError it raises is raised on every rank."""
        err = None
        if here:
            try:
                fn()
            except OSError as e:
                err = e
        if self.par is not None:
            self.par.agree(err)
        elif err is not None:
            raise err

    def _root(self, fn):
        """``fn()`` on rank 0 (the only process of a plain run); its OSError raised on every rank."""
        self._agreed(fn, self.root)

    def _write_walls(self, name):
        sim = self.sim
        names = [k for k in ("n", "elementSize", "psi", "v") if k in sim.walls.arrays]
        vtk.write_points(self.out / name, sim.host(sim.walls, "x")[0], dict(zip(names, sim.host(sim.walls, *names))))

    def _write_fluid(self, base):
        """The fluid's frame ``base``: one .vtu, or a rank's piece each and their .pvtu."""
        sim, par = self.sim, self.par
        x, v, rho, p, ids = sim.owned_host("x", "v", "rho", "p", "id")
        fields = {"rho": rho, "p": p, "v": v, "id": ids}
        if "kind" in sim.fluid.arrays:
            fields["kind"] = sim.owned_host("kind")[0]
        if par is None:
            vtk.write_points(self.out / f"{base}.vtu", x, fields)
            return f"{base}.vtu"
        piece = f"{base}_p{par.rank}.vtu"
        self._agreed(lambda: vtk.write_points(self.out / piece, x, fields), here=x.shape[1] > 0)
        counts = par.comm.gather(x.shape[1], root=0)
        self._root(lambda: vtk.write_pvtu(self.out / f"{base}.pvtu", [f"{base}_p{r}.vtu" for r, c in enumerate(counts)
                                                                      if c], fields))
        return f"{base}.pvtu"

    def write(self, failed=False, sample=True):
        """A VTK frame (when ``vtk`` is on) and, with ``sample``, a row of probes.csv."""
        sim = self.sim
        if sample and not failed:
            self.sample()  # refreshes p from the current density first
        else:
            sim.settle()
        if self.oc["vtk"]:
            name = self._write_fluid("fluid_failed" if failed else f"fluid_{self.count:04d}")
            if not failed:
                self.entries.append((sim.t, 0, name))

                def series():
                    if sim.walls.n and sim.bodies.moving:  # a frame of the walls too
                        wname = f"walls_{self.count:04d}.vtu"
                        self._write_walls(wname)
                        self.entries.append((sim.t, 1, wname))
                    elif sim.walls.n:
                        self.entries.append((sim.t, 1, "walls.vtu"))
                    vtk.write_pvd(self.out / "fluid.pvd", [e for e in self.entries if e[1] == 0])
                    vtk.write_pvd(self.out / "case.pvd", self.entries)

                self._root(series)
                if not self.root and sim.walls.n:  # the same list on every rank (checkpoints)
                    self.entries.append((sim.t, 1, f"walls_{self.count:04d}.vtu" if sim.bodies.moving
                                         else "walls.vtu"))
                self.last_good = f"{self.out / name} (t = {sim.t:.6g} s)"
        if not failed:
            self.count += 1

    def sample(self):
        """One row of probes.csv: time, energies, surge front, the probes, the scheme's figures."""
        sim, par = self.sim, self.par
        values = sim.probes.sample()  # refreshes p from the current density first
        x, v, m = sim.owned_host("x", "v", "m")
        ek, ep = probes.energies(x, v, m, sim.gravity)
        front = probes.surge_front(x, sim.dp) if x.shape[1] else -np.inf
        if par is not None:
            ek, ep = (float(e) for e in par.sum([ek, ep]))
            front = float(par.max([front])[0])
        row = {"time": sim.t, "step": sim.steps, "dt": float(sim.P.dt) if sim.steps else 0.0,
               "n_fluid": sim.n_fluid(), "kinetic_energy": ek, "potential_energy": ep}
        if self.oc["surge_front"]:
            row["surge_front"] = front if np.isfinite(front) else float("nan")
        row.update(values)
        row.update(sim.body_loads())
        stats = sim.integrator.stats
        row.update(stats)
        if "midpoint_iterations" in stats:
            row["midpoint_iterations_max"] = self.iter_max
            self.iter_max = 0
        self._root(lambda: self.probes.write(row))

    def log_step(self):
        """One row of ``steps.csv`` per step for schemes with per-step figures (midpoint
        iterations and residual, RK45 error and rejections)."""
        if not self.stats:
            return
        sim = self.sim
        stats = sim.integrator.stats
        self.iter_max = max(self.iter_max, stats.get("midpoint_iterations", 0))
        self._root(lambda: self.steps_log.write(dict(stats, step=sim.steps, time=sim.t, dt=float(sim.P.dt))))

    def checkpoint(self, next_out, next_probe):
        """``checkpoint.npz``: the state, and where the output series stands."""
        self._agreed(lambda: self.sim.save_checkpoint(self.out / "checkpoint.npz", {
            "entries": self.entries, "count": self.count, "iter_max": self.iter_max, "next_out": next_out,
            "next_probe": next_probe}))

    def close(self, summary):
        def finish():
            self.probes.close()
            if self.steps_log is not None:
                self.steps_log.close()
            vtk.write_text(self.out / "run.json", json.dumps(summary, indent=2) + "\n")

        self._root(finish)


def _frame(name):
    """The frame a file belongs to: ``fluid_0003`` of fluid_0003.vtu, .pvtu and its pieces."""
    import re

    return re.sub(r"(_p[0-9]+)?\.p?vtu$", "", name)
