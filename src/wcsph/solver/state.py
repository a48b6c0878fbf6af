"""The run state: what a step reads and writes, and nothing of how the steps are ordered.

``State`` holds the particle sets, the cell grid, the model and its parameters ``P``, the
decomposition over ranks (``par``, None in a plain run), the time and the step's scalars
(``dt``, ``vmax``, ``amax``, the counts). Every stage of a step (``solver.simulation`` lists them), the
integrators, the open boundaries, the probes and the output take a State; none of them
reaches into the driver. The scalars a stage produces for the next one (``vmax``, ``amax``,
``bad``, ``n_owned``) are fields here, so that a backend that keeps the state on a device
can keep them there too and have the host read them every few steps.
"""
import math

import numpy as np

from ..physics.integrators import StateView


class State:
    """A case's particles and scalars as the stages see them (set up by ``solver.setup``)."""

    def __init__(self, case, backend, grid, model, P, fluid, walls, *, domain, h, c0, mass, par=None, halo=None):
        self.case, self.backend = case, backend
        self.dim, self.dtype, self.dp = case["dim"], np.dtype(case["precision"]).type, case["dp"]
        self.h, self.c0, self.mass = h, c0, mass
        self.domain = domain  # (lo, hi): the box the particles live in
        self.grid, self.G = grid, grid.view()
        self.model, self.P, self.fluid, self.walls = model, P, fluid, walls
        self.par, self.halo = par, halo
        self.rho0 = case["physics"]["rho0"]
        self.gravity = np.asarray(case["physics"]["gravity"], dtype=float)
        self.t = 0.0
        self.steps = 0
        self.dt = 0.0  # the step being taken (the stages of one step read it); None: sized on the device
        self.dt_bound = 0.0  # the longest step the device may make (``solver.timestep``)
        self.lead = 0.0  # the most the steps sized on the device and not read yet can add to t
        self.walls_at = None  # t -> walls on prescribed paths placed at t (``solver.walls.clock``)
        self.walls_t = 0.0  # the time the moving walls were last placed at
        self.evaluations = 0  # derivative evaluations (integrator stages, midpoint iterations)
        self.dropped = 0  # fluid particles that left the domain
        self.vmax = 0.0  # |v| and |a| largest after the last step: the next step's size
        self.amax = float(np.linalg.norm(self.gravity))
        self.bad = 0  # fluid particles with a non-finite state after the last step
        self.n_owned = fluid.n  # this rank's own fluid particles after the last step
        # what the integrator's last map of a step may run in its loop (``tail``), as the
        # stages allow (``solver.simulation.fuse_tail``); ``corrected``: it ran the walls'
        self.tail_walls = self.tail_check = self.corrected = False
        self.fresh = False  # p and V are those of the current density (the sort made them)
        self._placeholders = {"k": backend.to_device(np.zeros((1, 1, 1), dtype=self.dtype)),
                              "w": backend.to_device(np.zeros(1, dtype=self.dtype))}

    # ------------------------------------------------------------------ what stages call
    def view(self, w=None):
        """The fluid as the integrators see it (``StateView``), with ``w`` the scheme's
        coefficients; stand-ins (of the right kind) for the fields this model or scheme
        lacks, which the scheme then never reads."""
        a = self.fluid.arrays
        x, v, rho = a["x"], a["v"], a["rho"]
        return StateView(x, v, a["dvdt"], rho, a.get("drhodt", rho), a["p"], a["m"], a.get("x_n", x), a.get("v_n", v),
                         a.get("rho_n", rho), a.get("dv_t", v), a.get("drho_t", rho),
                         a.get("k", self._placeholders["k"]), self._placeholders["w"] if w is None else w)

    def gravity_factor(self, t):
        """Gravity switched on smoothly over ``physics.gravity_ramp_time`` t_d, Adami, Hu &
        Adams (2012): g(t) = g (sin((t/t_d - 1/2) pi) + 1) / 2, so that a column at rest starts
        without the pressure wave a sudden load excites."""
        td = self.case["physics"]["gravity_ramp_time"]
        if td <= 0 or t >= td:
            return 1.0
        return 0.5 * (math.sin((t / td - 0.5) * math.pi) + 1.0)

    def params_for(self, dt, vmax=None):
        """The model parameters for a step of size ``dt`` from the current time (``vmax``: the
        largest speed they hold, by default the state's)."""
        return self.model.update(self.P, dt, self.gravity * self.gravity_factor(self.t),
                                 self.vmax if vmax is None else vmax)

    def swap(self, pairs):
        """Each (a, b) of ``pairs``: the fluid's arrays a and b trade names."""
        f = self.fluid
        for a, b in pairs:
            f[a], f[b] = f[b], f[a]

    def evaluate(self, P, at=0.0, refreshed=False, then=None):
        """The model's derivatives at the current state (called by the integrator), which is
        that of the time t + ``at`` dt (dt = ``P.dt``): walls on prescribed paths are placed
        there first; a decomposed run first refreshes its ghosts' state from their owners.
        ``refreshed``: the integrator's map before this evaluation refreshed p and V
        (``Integrator.fuse_refresh``), as the sort may have at the step's start (``fresh``).
        ``then``: the interaction pass to run instead of the model's, with its views
        (``Integrator.fuse_first``)."""
        self.evaluations += 1
        refreshed, self.fresh = refreshed or self.fresh, False
        if self.walls_at is not None:
            self.walls_at(self.t + at * float(P.dt))
        if self.par is not None:
            self.par.update(self.fluid, self.model.exchanged["state"])
        self.model.derivatives(self.fluid, self.walls, P, self.G, self.halo, refreshed, then)

    def tail(self):
        """What the integrator's last map of this step runs in its loop besides its own update
        (``Integrator.end_step``): (F, J, G, measure) with F, J the views of the model's wall
        corrections (None: none) and ``measure`` (the fluid, the grid) when the check may be
        made there; None when neither may this step (a pass of the model's after the step
        comes first)."""
        if not (self.tail_walls or self.tail_check) or self.model.after_step_due(self.steps + 1):
            return None
        measure = (self.fluid, self.grid) if self.tail_check else None
        if not self.tail_walls:
            return None, None, None, measure
        self.corrected = True
        return (*self.model.tail_views(self.fluid, self.walls), self.G, measure)

    def refresh_view(self):
        """The view of the fluid the model's ``refresh_fn`` takes."""
        return self.model.refresh_view(self.fluid)

    def reduce(self, fn, view, P):
        """A reduction map of the integrator (``backend.make_reduce``): (sum, sum, max) over
        the particles, over every rank's own in a decomposed run."""
        if self.par is None:
            return fn(view, P)
        a, b, c = fn(view, P, self.fluid["owned"])
        s = self.par.sum([a, b])
        return float(s[0]), float(s[1]), float(self.par.max([c])[0])

    def settle(self):
        """p and V from the current density (``model.refresh``) and, in a decomposed run,
        the ghosts' state and those fields from their owners: what corrections, probes and
        body loads read of a neighbour after a step."""
        self.model.refresh(self.fluid, self.P)
        if self.par is not None:
            self.par.update(self.fluid, self.model.exchanged["settled"])

    # ------------------------------------------------------------------ host reads
    def host(self, pset, *names):
        """Host copies of ``names`` of a particle set."""
        return [self.backend.to_host(pset[k]) for k in names]

    def owned_host(self, *names):
        """Host copies of the fluid's ``names``, of this rank's own particles only."""
        arrays = self.host(self.fluid, *names)
        if self.par is None:
            return arrays
        mine = self.backend.to_host(self.fluid["owned"]) != 0
        return [a[..., mine] for a in arrays]

    def n_fluid(self):
        """Fluid particles in the case (over every rank)."""
        if self.par is None:
            return self.fluid.n
        return int(self.par.sum([self.par.n_owned])[0])
