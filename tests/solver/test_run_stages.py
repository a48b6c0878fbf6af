"""The run's stages on their own, without a case: each takes a state and nothing else, so a
namespace with the fields it reads is enough to test it."""
from types import SimpleNamespace

import pytest

from wcsph.errors import SimulationError
from wcsph.solver.check import Check
from wcsph.solver.loop import Every
from wcsph.solver.timestep import TimeStep

TIME = {"dt": 0.0, "dtInit": 0.0, "dtMin": 0.0, "force_cfl": 0.25}


class _Integrator:
    def propose(self, dt):
        return dt


def _state(**kw):
    s = dict(t=1.5, steps=7, h=0.02, c0=20.0, vmax=2.0, amax=9.81, n_owned=100, bad=0, dt=1e-3, lead=0.0)
    s.update(kw)
    return SimpleNamespace(**s)


def test_the_step_is_the_least_of_the_three_limits():
    s = _state()
    cfl = TimeStep(TIME, 0.2, _Integrator(), nu=0.0)(s)
    assert cfl == pytest.approx(0.2 * 0.02 / (20.0 + 2.0))
    force = TimeStep(TIME, 0.2, _Integrator(), nu=0.0)(_state(amax=1e5))
    assert force == pytest.approx(0.25 * (0.02 / 1e5) ** 0.5)
    viscous = TimeStep(TIME, 0.2, _Integrator(), nu=1.0)(s)
    assert viscous == pytest.approx(0.125 * 0.02 ** 2 / 1.0)


def test_a_constant_or_first_step_is_taken_as_given_and_dt_min_stops_the_run():
    assert TimeStep(dict(TIME, dt=1e-4), 0.2, _Integrator(), 0.0)(_state()) == 1e-4
    assert TimeStep(dict(TIME, dtInit=1e-6), 0.2, _Integrator(), 0.0)(_state(steps=0)) == 1e-6
    with pytest.raises(SimulationError, match="dtMin"):
        TimeStep(dict(TIME, dtMin=1.0), 0.2, _Integrator(), 0.0)(_state())


@pytest.mark.parametrize("fields, words", [({"n_owned": 0}, "left the domain"), ({"bad": 3}, "3 fluid particles"),
                                           ({"vmax": 25.0}, "runaway velocity")])
def test_the_check_names_the_step_it_stops_at(fields, words):
    with pytest.raises(SimulationError, match=words) as e:
        Check.verify(_state(**fields))
    assert "step 7" in str(e.value) and "t = 1.5 s" in str(e.value)


def test_a_sound_state_passes_the_check():
    Check.verify(_state())


def test_a_callback_falls_due_each_interval_and_never_at_zero():
    calls = []
    every = Every(0.1, 0.0, lambda: calls.append(1))
    for t in (0.0, 0.05, 0.1, 0.1999999999, 0.25, 0.3):  # within the slack of 0.2 counts as 0.2
        if every.due(t, slack=1e-9):
            every()
    assert len(calls) == 4 and every.next == pytest.approx(0.4)
    assert not Every(0.0, 0.0, lambda: None).due(5.0, 1e-9)


def test_the_stages_of_a_case_follow_from_it():
    """A case without open boundaries has no inflow stages; one with them has both, around the
    integrator; walls on a prescribed path are placed at the step's end before the after-step
    passes (they correct positions against the wall where it then is), a floating body's walls
    after its step, after the time advanced; the check comes last."""
    from types import SimpleNamespace

    from wcsph.solver.simulation import stages

    integrator = SimpleNamespace(opens_with_evaluation=True, continuity=True)
    fixed = SimpleNamespace(floating={}, prescribed=False)
    floating = SimpleNamespace(floating={1: object()}, prescribed=False)
    moving = SimpleNamespace(floating={}, prescribed=True)
    rule = TimeStep(TIME, 0.2, _Integrator(), nu=0.0)
    names = [type(s).__name__ for s in stages(rule, integrator, fixed, None)]
    assert "InflowBefore" not in names and "WallsAtStepEnd" not in names and names[-2:] == ["Advance", "Check"]
    names = [type(s).__name__ for s in stages(rule, integrator, floating, None)]
    assert names[-4:] == ["Advance", "MoveBodies", "MoveWalls", "Check"]
    names = [type(s).__name__ for s in stages(rule, integrator, moving, None)]
    assert names[names.index("Integrate") + 1:names.index("Integrate") + 3] == ["WallsAtStepEnd", "AfterStep"]
    assert "MoveWalls" not in names
    opened = [type(s).__name__ for s in stages(rule, integrator, fixed, object())]
    assert opened.index("InflowBefore") < opened.index("Integrate") < opened.index("InflowAfter")
    assert stages(rule, integrator, fixed, None)[1].refresh and not stages(rule, integrator, fixed, object())[1].refresh


def _run_bi(extra, fused=True, steps=6):
    import numpy as np

    import wcsph
    from wcsph.case.config import load

    case = load("dam_break_2d_bi", [("dp", 0.05), ("precision", "float64"), ("time.dt", 2e-3),
                                    ("output.progress", False)] + list(extra.items()))
    sim = wcsph.Simulation(case, backend="cpu")
    if not fused:
        sim.state.tail_walls = sim.state.tail_check = False
    taken = []
    tail = sim.state.tail
    sim.state.tail = lambda: taken.append(tail()) or taken[-1]
    for _ in range(steps):
        sim.step(sim.time_step())
    x, v, rho, ids = sim.host(sim.fluid, "x", "v", "rho", "id")
    o = np.argsort(ids)
    return np.concatenate([x[:, o].ravel(), v[:, o].ravel(), rho[o]]), sum(t is not None for t in taken)


def test_the_wall_corrections_in_the_last_map_are_those_of_their_own_stage():
    """``dam_break_2d_bi`` (an inelastic bounce off the walls after each step), the bounce
    run in the corrector's own loop (``State.tail``, the GPU's one launch) and as a stage of
    its own: the same numbers, bit for bit. With CSPM's density re-initialisation every
    second step, which comes before the bounce, the corrector takes it every other step (3
    of 6). The bounce does act here (without it the state differs)."""
    import numpy as np

    extra = {"model.kernel_correction": "CSPM", "model.cspm_density_interval": 2}
    fused, n = _run_bi(extra)
    apart, m = _run_bi(extra, fused=False)
    assert n == 3 and m == 0
    assert np.array_equal(fused, apart)
    free, _ = _run_bi(dict(extra, **{"model.enableElasticBounce": False}))
    assert not np.array_equal(fused, free)


class _Ring:
    """A backend whose check leaves each step's figures on a 'device' until read."""

    defers_check = True

    def __init__(self, rows):
        self.rows, self.measured, self.reads, self.finished, self.sorts = rows, [], 0, 0, 0

    def check_later(self, pset, row, rows):
        self.measured.append(self.rows[len(self.measured)])

    def start_read(self, pset, rows):
        self.reads += 1
        out, self.measured = self.measured[:rows], self.measured[rows:]
        return out

    def finish_read(self, pset, handle):
        self.finished += 1
        return handle

    def sort(self, pset, grid):
        self.sorts += 1
        return 2


def _deferred(rows, every, dt_min=0.0):
    be = _Ring(rows)
    s = _state(backend=be, fluid=SimpleNamespace(n=100), grid=None, dropped=0, c0=20.0, steps=0, t=0.0,
               params_for=lambda dt: SimpleNamespace(dt=dt))
    check = Check(dt_min)
    check.defer(every)
    return s, be, check


def test_checks_read_every_few_steps_name_the_first_bad_step():
    """Rows measured on a device are copied every ``every`` steps and verified in step order
    a read later (the copy runs while the device goes on): a runaway at the second step
    stops the run when the copy after the third is verified, at the read after the sixth,
    naming the second; a read the time loop asks for verifies every row at once."""
    ok, fast = (1.0, 1.0, 0, 0, 0.0), (900.0, 1.0, 0, 0, 0.0)  # |v|^2 = 900: 30 m/s against c0 = 20
    for forced in (False, True):
        s, be, check = _deferred([ok, fast] + [ok] * 4, every=3)
        for k in (1, 2, 3):
            s.steps, s.t = k, 0.1 * k
            check(s)
        assert be.reads == 1 and be.finished == 0 and check.in_flight is not None
        with pytest.raises(SimulationError, match="runaway") as e:
            if forced:
                check.read(s)
            else:
                for k in (4, 5, 6):
                    s.steps, s.t = k, 0.1 * k
                    check(s)
        assert "step 2" in str(e.value) and "t = 0.2 s" in str(e.value) and be.finished == 1
        assert be.reads == (1 if forced else 2)


def test_a_read_that_finds_particles_outside_drops_them():
    """Rows that counted particles outside the grid: the read drops them with a sort, and
    the state's count of particles is the row's; nothing pending after a read."""
    s, be, check = _deferred([(1.0, 1.0, 0, 0, 0.0), (1.0, 1.0, 0, 2, 0.0)], every=4)
    for k in (1, 2):
        s.steps, s.t = k, 0.1 * k
        check(s)
    check.read(s)
    assert be.reads == 1 and be.sorts == 1 and s.dropped == 2 and s.n_owned == 98 and not check.pending
    check.read(s)  # nothing left to read: no copy
    assert be.reads == 1


def test_steps_sized_on_the_device_move_the_time_on_at_the_read():
    """Rows of steps the device sized carry the size: the read sums the time from them (after
    the host-sized step that opened the batch), names a bad step at its own time, and stops
    on a size below ``dtMin`` made at the step's start."""
    rows = [(1.0, 1.0, 0, 0, 0.0), (1.0, 1.0, 0, 0, 2e-3), (900.0, 1.0, 0, 0, 3e-3)]
    s, be, check = _deferred(rows, every=4)
    s.steps, s.t, s.dt = 1, 1e-3, 1e-3  # sized on the host: its time already summed
    check(s)
    s.dt, s.lead = None, 0.0
    for k in (2, 3):  # sized on the device: t stays, the lead bounds what they add
        s.steps, s.lead = k, s.lead + 5e-3
        check(s)
    with pytest.raises(SimulationError, match="runaway") as e:
        check.read(s)
    assert "step 3" in str(e.value) and "t = 0.006 s" in str(e.value)
    assert s.t == 1e-3 + 2e-3 + 3e-3 and s.lead == 0.0 and not check.pending
    assert s.dt == 3e-3 and s.P.dt == 3e-3  # the last step's, as the host would have it

    s, be, check = _deferred([(1.0, 1.0, 0, 0, 0.0), (1.0, 1.0, 0, 0, 1e-7)], every=4, dt_min=1e-6)
    s.steps, s.t, s.dt = 1, 1e-3, 1e-3
    check(s)
    s.steps, s.dt = 2, None
    check(s)
    with pytest.raises(SimulationError, match="dtMin") as e:
        check.read(s)
    assert "t = 0.001 s" in str(e.value)


def test_the_device_sizes_the_step_only_where_nothing_on_the_host_reads_it_within():
    """An adaptive step is sized on the device (``simulation.size_on_device``) unless the
    scheme sizes its own (the implicit midpoint's iterations, RK45's error control), a wall
    moves on a prescribed path (placed on the host at each evaluation's time), a damping
    zone relaxes over dt, or the step is constant (nothing to size)."""
    import numpy as np

    from wcsph.backends.cpu import CpuBackend
    from wcsph.physics.integrators import RK4, RK45, ImplicitMidpoint, SymplecticVerlet
    from wcsph.solver.simulation import size_on_device

    adaptive, constant = SimpleNamespace(case={"time": {"dt": 0.0}}), SimpleNamespace(case={"time": {"dt": 1e-4}})
    still, moving = SimpleNamespace(prescribed=False), SimpleNamespace(prescribed=True)
    be = CpuBackend()
    verlet, midpoint = SymplecticVerlet(be, 2, True, np.float64), ImplicitMidpoint(be, 2, True, np.float64)
    rk45, rk4 = RK45(be, 2, True, np.float64), RK4(be, 2, True, np.float64)
    assert size_on_device(adaptive, verlet, still) and size_on_device(adaptive, rk4, still)
    assert not size_on_device(adaptive, midpoint, still) and not size_on_device(adaptive, rk45, still)
    assert not size_on_device(adaptive, verlet, moving) and not size_on_device(adaptive, verlet, still, object())
    assert not size_on_device(constant, verlet, still)
