"""``Simulation``: a case set up (``solver.setup``) and the ordered stages of its step.

A step is the list ``stages``, each a callable of the run state (``solver.state.State``):

1. the step's parameters (``TimeStep.parameters``; a size made on the device, launched);
2. ``Sort``: the particles by cell (in a decomposed run: migrated, ghosts exchanged; with a
   continuity density, p and V of the step's start made there);
3. ``InflowBefore``: the open boundaries' buffers kept (cases with open boundaries);
4. ``Integrate``: the integrator's evaluations and maps (each places the walls on prescribed
   paths at its time: ``solver.walls``);
4b. ``WallsAtStepEnd``: those walls at the step's end time (cases with them);
5. ``AfterStep``: the model's after-step passes;
6. ``InflowAfter``: buffers prescribed, particles enter and leave;
6b. ``Damping``: the velocity relaxed in damping zones (cases with ``[[damping]]``);
7. ``Advance``: periodic wrap, time and step count;
8. ``MoveBodies``: the floating bodies' step under the fluid's loads and gravity (cases with
   floating bodies);
9. ``MoveWalls``: the floating bodies' walls to their new place (cases with floating bodies);
10. ``Check``: speeds for the next step, and the stop on a non-physical state.

Between steps the time loop (``solver.loop``) writes frames, probes and checkpoints and
watches for signals.
"""
import time

from . import parallel
from ..backends import get_backend
from ..errors import CaseError
from ..io.probes import PointProbes
from . import checkpoint, loop, setup
from .advance import Advance
from .after_step import AfterStep
from .check import Check
from .damping import Damping
from .floating import MoveBodies
from .inflow import InflowAfter, InflowBefore
from .integrate import Integrate
from .loads import body_loads
from .sort import Sort
from .timestep import TimeStep
from .walls import MoveWalls, WallsAtStepEnd


def stages(rule, integrator, bodies, open_boundaries, damping=None):
    """The ordered stages of a step (the module docstring lists them); the inflow stages only
    for a case with open boundaries, the damping only with damping zones. ``rule``: the
    ``TimeStep``."""
    integrate = Integrate(integrator)
    inflow = [InflowBefore(open_boundaries)] if open_boundaries is not None else []
    outflow = [InflowAfter(open_boundaries)] if open_boundaries is not None else []
    floating = [MoveBodies(bodies), MoveWalls(bodies)] if bodies.floating else []
    damped = [damping] if damping is not None else []
    walls = [WallsAtStepEnd()] if bodies.prescribed else []
    refresh = open_boundaries is None and integrator.opens_with_evaluation and integrator.continuity
    return [rule.parameters, Sort(refresh), *inflow, integrate, *walls, AfterStep(), *outflow, *damped,
            Advance(), *floating, Check(rule.tc["dtMin"])]


def fuse_tail(state, integrator, bodies, open_boundaries, damping=None):
    """Let the integrator's last map of a step run the model's wall corrections (the elastic
    bounce, NBVC-PST) and the check in its own loop where no stage between them changes what
    they read: the walls stand where the corrections would see them (no prescribed motion),
    and nothing moves the fluid between that map and the check's stage (no open boundary,
    damping zone or periodic wrap). A decomposed run keeps its stages apart (its ghosts are
    refreshed between them). The check is fused only by a backend that does it in the same
    launch (``fuses_check``); a step after which one of the model's other after-step passes
    runs keeps them apart as well (``State.tail``)."""
    model = state.model
    if state.par is not None or state.grid.any_periodic:
        return
    walk = model.correction_walk if state.walls.n else None
    if model.wall_corrections and (walk is None or bodies.prescribed):
        return  # the corrections after the last map, and then the check, stay stages
    state.tail_walls = walk is not None
    state.tail_check = (state.backend.fuses_check and open_boundaries is None and damping is None)
    if state.tail_walls or state.tail_check:
        integrator.fuse_tail(walk, model.wall_corrections[0] if walk is not None else None)


def read_every_few_steps(state, integrator, bodies, open_boundaries, damping=None):
    """Whether the host may read the check's figures every ``time.check_interval`` steps
    (``solver.check``): a backend that keeps them on its device, one process, no open boundary
    or floating body, no choice that reads the step's largest speed, and a constant time step
    or one the device can size (``size_on_device``)."""
    case = state.case
    return (state.backend.defers_check and case["time"]["check_interval"] > 1
            and state.par is None and open_boundaries is None and not bodies.floating
            and "speed" not in state.model.implies and (case["time"]["dt"] > 0 or size_on_device(state, integrator, bodies, damping)))


def size_on_device(state, integrator, bodies, damping=None):
    """Whether a device may make the adaptive step's size (``solver.timestep``): nothing on the
    host reads it within the step. So the scheme takes the stability conditions' step as it
    is (``Integrator.takes_stable_step``), no wall moves on a prescribed path (placed at each
    evaluation's time) and no damping zone (relaxed over dt). The fields of P that depend on
    dt the device makes with it (``Model.stepped_values``)."""
    return (state.case["time"]["dt"] <= 0 and integrator.takes_stable_step and not bodies.prescribed
            and damping is None)


class Simulation:
    """A case set up on a backend, ready to step. ``case`` is a validated case dict.
    ``comm``: the MPI communicator to share the case over (``parallel``); by default the
    world of ``mpiexec``/``srun`` when started by one with several processes, else none.

    The run state's fields read through (``sim.fluid``, ``sim.t``, ``sim.P``, ...)."""

    def __init__(self, case, backend=None, comm="world"):
        t_setup = time.perf_counter()
        try:
            comm = parallel.world() if comm == "world" else comm
        except parallel.ParallelError as e:
            raise CaseError(str(e)) from None
        name = backend or case["backend"]
        if comm is not None and comm.Get_size() > 1 and name == "cuda":
            parallel.select_gpu(comm)  # before the backend makes a CUDA context
        built = setup.build(case, get_backend(name), comm)
        self.__dict__.update(state=built.state, case=case, integrator=built.integrator, bodies=built.bodies,
                             open=built.open, cfl=built.cfl, warnings=built.warnings, resumed_output=None)
        self.probes = PointProbes(self.state)
        self.time_step_rule = TimeStep(case["time"], self.cfl, self.integrator, self.model.kinematic_viscosity())
        damping = Damping(self.backend, self.dim, case["damping"]) if case["damping"] else None
        self.stages = stages(self.time_step_rule, self.integrator, self.bodies, self.open, damping)
        fuse_tail(self.state, self.integrator, self.bodies, self.open, damping)
        self.check = next(s for s in self.stages if isinstance(s, Check))
        if read_every_few_steps(self.state, self.integrator, self.bodies, self.open, damping):
            self.check.defer(case["time"]["check_interval"])
            if size_on_device(self.state, self.integrator, self.bodies, damping):
                self.time_step_rule.size_on_device(self.check)
        self.setup_time = time.perf_counter() - t_setup  # compiles (or loads) the loops

    def __getattr__(self, name):  # the run state's fields
        if name in ("t", "dt") and "check" in self.__dict__:
            self.read_checks()  # steps a device sized and the host has not read move the time on
        return getattr(self.__dict__["state"], name)

    def __setattr__(self, name, value):
        if name not in self.__dict__ and "state" in self.__dict__ and hasattr(self.state, name):
            setattr(self.state, name, value)
        else:
            self.__dict__[name] = value

    def time_step(self):
        """The next step's size (``solver.timestep``)."""
        return self.time_step_rule(self.state)

    def read_checks(self):
        """The checks the device holds, read and verified (before the host looks at the state)."""
        self.check.read(self.state)

    def host(self, pset, *names):
        """Host copies of ``names`` of a particle set, after the device's pending checks
        (a particle parked between two reads is dropped first)."""
        self.read_checks()
        return self.state.host(pset, *names)

    def step(self, dt):
        """One time step of at most ``dt`` through the stages; returns the step taken (an
        adaptive integrator may take less)."""
        self.state.dt = dt
        for stage in self.stages:
            stage(self.state)
        return self.state.dt

    def body_loads(self):
        """Force and torque of the fluid on each named body (``solver.loads``)."""
        return body_loads(self.state, self.bodies)

    def save_checkpoint(self, path, output_state=None):
        self.read_checks()
        checkpoint.save(path, self.state, self.integrator, self.open, output_state, self.bodies)

    read_checkpoint = staticmethod(checkpoint.read)

    def restore(self, meta, arrays, source="checkpoint"):
        """Continue from a checkpoint of the same case (``solver.checkpoint``)."""
        self.resumed_output = checkpoint.restore(self.state, self.integrator, self.open, meta, arrays, source,
                                                 self.bodies)
        MoveWalls(self.bodies)(self.state)

    def run(self, output=None, end_time=None, progress=None):
        """Step to ``end_time`` (default the case's); write output to directory ``output``
        (nothing if None). Returns the run summary (also written to ``run.json``)."""
        return loop.run(self, output, end_time, progress)
