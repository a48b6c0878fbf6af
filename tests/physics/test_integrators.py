"""Time integrators: order of accuracy on a smooth problem, energy behaviour of the implicit
midpoint scheme, its stability beyond the explicit limit, adaptive RK45, the midpoint
parameters and log."""
import csv

import numpy as np
import pytest

import wcsph
from wcsph.case.config import validate
from wcsph.errors import CaseError

T_SMOOTH = 0.02
DP = 0.01
U = 0.05


def _smooth_run(scheme, n, **time):
    """A 10 x 10 patch of WCSPH-BI fluid in free space (no walls, no gravity, inviscid, no
    diffusive term), float64, with the smooth velocity field v = U (sin 2pi y/L, cos 2pi x/L),
    run to T = 0.02 s (about 100 acoustic times h/c0) in n equal steps. h = 1.9 dp puts the
    kernel support (3.8 dp) between the lattice distances sqrt(13) dp and 4 dp; particles move
    less than U T = 0.1 dp, so no pair enters or leaves the support and the right-hand side
    is smooth in time, as an order measurement needs."""
    case = {"dim": 2, "dp": DP, "precision": "float64",
            "time": dict({"end": T_SMOOTH, "dt": T_SMOOTH / n, "integrator": scheme}, **time),
            "physics": {"gravity": [0.0, 0.0], "speed_of_sound": 10.0},
            "model": {"name": "bi", "h": 1.9 * DP, "DiffusiveTerm": "None", "enableElasticBounce": False,
                      "enableNearBoundaryShifting": False},
            "domain": {"min": [-0.1, -0.1], "max": [0.2, 0.2]},
            "fluid": [{"min": [0.0, 0.0], "max": [0.1, 0.1]}], "output": {"progress": False}}
    sim = wcsph.Simulation(validate(case))
    x = sim.host(sim.fluid, "x")[0]
    sim.fluid["v"] = np.stack([U * np.sin(2 * np.pi * x[1] / 0.1), U * np.cos(2 * np.pi * x[0] / 0.1)])
    sim.run(end_time=T_SMOOTH, progress=False)
    assert sim.steps == n
    ids, x, v, rho = sim.host(sim.fluid, "id", "x", "v", "rho")
    o = np.argsort(ids)
    return x[:, o], v[:, o], rho[o]


@pytest.fixture(scope="module")
def smooth_reference():
    """RK45 with 1600 fixed steps: its error (about 1e-14, extrapolated from the measured
    fifth-order decay) is far below the smallest error measured against it."""
    return _smooth_run("rk45", 1600)


def _error(a, ref):
    """Largest error over particles, scaled: positions by dp, velocities by U, density by
    the acoustic scale rho0 U / c0."""
    return max(np.abs(a[0] - ref[0]).max() / DP, np.abs(a[1] - ref[1]).max() / U,
               np.abs(a[2] - ref[2]).max() / (1000.0 * U / 10.0))


# measured (error vs dt, slope of the log-log fit; README "Time integration"):
#   symplectic Euler 1.05-1.20, Verlet 2.00 (f_ES = 0), symplectic Verlet 2.00,
#   implicit midpoint 2.00, RK4 3.96-3.99, RK45 4.89-5.05
ORDERS = [("symplectic_euler", 1, (100, 200, 400), {}),
          ("verlet", 2, (100, 200, 400), {"verlet_euler_interval": 0}),
          ("symplectic_verlet", 2, (100, 200, 400), {}),
          ("midpoint", 2, (100, 200, 400), {"midpointResidualTolerance": 1e-13, "midpointMaxInterations": 200}),
          ("rk4", 4, (50, 100, 200), {}),
          ("rk45", 5, (50, 100, 200), {})]


@pytest.mark.parametrize("scheme,order,steps,extra", ORDERS, ids=[o[0] for o in ORDERS])
def test_order_of_accuracy(scheme, order, steps, extra, smooth_reference):
    errors = [_error(_smooth_run(scheme, n, **extra), smooth_reference) for n in steps]
    slope = np.polyfit(np.log(T_SMOOTH / np.array(steps)), np.log(errors), 1)[0]
    print(f"{scheme}: errors {errors}, order {slope:.2f}")
    assert abs(slope - order) < 0.3, (slope, errors)


def test_verlet_euler_steps_cost_accuracy(smooth_reference):
    """An Euler step every f_ES = 40 steps (the default) is first order locally: measured
    2.4e-3, 6.0e-4, 3.7e-4, 1.1e-4 at 100..800 steps (slope 1.5, between 1 and 2), against
    2.1e-3 ... 3.2e-5 without. It must stay within a few times the pure leapfrog error here."""
    for n in (200, 400):
        with_euler = _error(_smooth_run("verlet", n), smooth_reference)
        pure = _error(_smooth_run("verlet", n, verlet_euler_interval=0), smooth_reference)
        print(n, with_euler, pure)
        assert pure <= with_euler < 5 * pure


# ------------------------------------------------------------------ implicit midpoint
C0 = 10.0


def _slosh(scheme, corrections, **time):
    """A closed 0.3 x 0.2 m box, half full (30 x 10 particles, float64), conservative
    WCSPH-BI walls, inviscid, no diffusive term, linearized Cole EOS (p0 = 0), gravity, and
    a standing-wave velocity v_y = 0.1 cos(pi x/0.3) m/s to start it sloshing."""
    case = {"dim": 2, "dp": 0.01, "precision": "float64",
            "time": dict({"end": 100.0, "integrator": scheme, "force_cfl": 100.0}, **time),
            "physics": {"gravity": [0.0, -9.81], "speed_of_sound": C0},
            "model": {"name": "bi", "DiffusiveTerm": "None", "ViscousTerm": "None",
                      "enableElasticBounce": corrections, "enableNearBoundaryShifting": corrections},
            "tank": {"min": [0.0, 0.0], "max": [0.3, 0.2], "open_top": False},
            "fluid": [{"min": [0.0, 0.0], "max": [0.3, 0.1]}], "output": {"progress": False}}
    sim = wcsph.Simulation(validate(case))
    x = sim.host(sim.fluid, "x")[0]
    sim.fluid["v"] = np.stack([0.0 * x[0], 0.1 * np.cos(np.pi * x[0] / 0.3)])
    return sim


def _total_energy(sim):
    """Kinetic + potential + internal energy, sum m (|v|^2/2 - g.x + e(rho)), with the
    internal energy of the linearized Cole EOS (p0 = 0): de = p/rho^2 drho, so
    e(rho) = c0^2 (ln rho + rho0/rho) - e(rho0)."""
    x, v, rho, m = sim.host(sim.fluid, "x", "v", "rho", "m")
    rho0 = sim.rho0
    e = lambda r: C0 ** 2 * (np.log(r) + rho0 / r)  # noqa: E731
    ek = 0.5 * float((m * (v ** 2).sum(axis=0)).sum())
    ep = -float((m * (sim.gravity[:, None] * x).sum(axis=0)).sum())
    return ek, ek + ep + float((m * (e(rho) - e(rho0))).sum())


def _energy_drift(scheme, steps, dt):
    sim = _slosh(scheme, corrections=False, dt=dt)
    ek0, e0 = _total_energy(sim)
    worst = 0.0
    for k in range(steps):
        sim.step(dt)
        if k % 100 == 99:
            worst = max(worst, abs(_total_energy(sim)[1] - e0) / ek0)
    return worst


def test_midpoint_keeps_energy_where_explicit_drifts():
    """10^4 steps at dt = 0.25 h/c0 (about 4.9 s, a dozen slosh periods) with nothing that
    dissipates or adds energy (no viscosity, no diffusive term, no wall corrections): the
    conservative WCSPH-BI equations conserve E exactly, so any change is the integrator's.
    Measured, as a fraction of the initial kinetic energy: implicit midpoint 5.8e-5 (the
    test allows 1e-3, i.e. 0.1 %); symplectic Verlet +41 (x Ek0: the wall pressure pumps
    energy in), Verlet +55, RK4 -4.4e-3 (from the README table)."""
    dt = 0.25 * 0.02 / C0
    imp = _energy_drift("midpoint", 10_000, dt)
    sv = _energy_drift("symplectic_verlet", 10_000, dt)
    print(f"|E - E0| / Ek0 over 1e4 steps: implicit midpoint {imp:.2e}, symplectic Verlet {sv:.2e}")
    assert imp < 1e-3
    assert sv > 10 * imp


def test_midpoint_is_stable_beyond_the_explicit_limit():
    """The same box with the wall corrections on. Symplectic Verlet's largest stable CFL
    number here is 0.5 (measured: 0.75 runs away; already at 0.5 the energy grows 70-fold
    in 0.5 s); the implicit midpoint with relaxation (w = 0.7) stays stable at cfl 4.0, eight
    times that (it fails at 6). Here: cfl 2.0, four times, for 0.25 s, against symplectic
    Verlet running away within 0.5 s at cfl 1.0."""
    sim = _slosh("midpoint", corrections=True, cfl=2.0, midpointRelaxCoef=0.7, midpointRelaxCoef_0=0.7,
                 midpointMaxInterations=300, midpointResidualTolerance=1e-6)
    ek0, e0 = _total_energy(sim)
    sim.run(end_time=0.25, progress=False)
    ek, e = _total_energy(sim)
    assert abs(e - e0) < 0.5 * ek0 and ek < 3 * ek0, (e - e0, ek, ek0)
    explicit = _slosh("symplectic_verlet", corrections=True, cfl=1.0)
    with pytest.raises(wcsph.SimulationError):
        explicit.run(end_time=0.5, progress=False)


def test_midpoint_parameters_and_log(tmp_path):
    """The spec's midpoint names, in [time] or in [parameters]; iterations and the final
    residual per step in steps.csv and in probes.csv."""
    case = wcsph.case.config.load("hydrostatic_2d_bi", [("time.end", 0.01), ("dp", 0.05), ("time.integrator", "MidpointScheme"),
                                                  ("parameters.midpointMaxInterations", 7),
                                                  ("time.midpointResidualTolerance", 1e-30)])
    assert case["time"]["midpointMaxInterations"] == 7
    sim = wcsph.Simulation(case)
    assert type(sim.integrator).__name__ == "ImplicitMidpoint"
    sim.run(tmp_path, progress=False)
    rows = list(csv.DictReader(open(tmp_path / "steps.csv")))
    assert len(rows) == sim.steps
    assert all(int(r["midpoint_iterations"]) <= 7 for r in rows)
    assert all(float(r["midpoint_residual"]) > 0 for r in rows)
    probes = list(csv.DictReader(open(tmp_path / "probes.csv")))
    assert {"midpoint_iterations", "midpoint_residual", "midpoint_iterations_max"} <= set(probes[-1])


@pytest.mark.parametrize("scheme", ["symplectic_verlet", "rk4", "midpoint"])
def test_a_map_that_refreshes_p_and_v_in_its_loop_changes_no_number(scheme):
    """The predictor (Verlet), the save and stage maps (Runge-Kutta) and the midpoint state
    of each iteration (implicit midpoint) run the model's
    p and V from rho in their own loop, and the evaluation after them starts with the walls
    (one launch fewer on a GPU per map): bit-for-bit the numbers of the separate map. The
    refresh reads the density through the map's own view: read through the model's view of
    the same array, the compiled loop once took the density from before the stage's write
    (RK4's pressure 330 Pa off after one step)."""
    res = []
    for fused in (True, False):
        case = validate({"dim": 2, "dp": 0.02, "precision": "float64",
                         "time": {"end": 1.0, "max_steps": 6, "integrator": scheme},
                         "fluid": [{"min": [0.0, 0.0], "max": [0.2, 0.4]}],
                         "tank": {"min": [0.0, 0.0], "max": [0.6, 0.5], "open_top": True},
                         "model": {"name": "bi", "BCType": "BIConsistent_numeric"}, "output": {"progress": False}})
        sim = wcsph.Simulation(case)
        assert sorted(sim.integrator.fused) == {"symplectic_verlet": [0], "rk4": [0, 1], "midpoint": [2]}[scheme]
        if not fused:
            sim.integrator.fused = {}
        sim.run()
        res.append(sim.host(sim.fluid, "x", "v", "rho", "p"))
    for a, b in zip(*res):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("key,value,message", [
    ("time.midpointRelaxCoef", 1.0, "time.midpointRelaxCoef: must lie in [0, 1)"),
    ("time.midpointMaxInterations", 0, "time.midpointMaxInterations: must be positive"),
    ("time.integrator", "leapfrog", "time.integrator: must be one of"),
    ("parameters.midpointResidualTolerance", -1.0, "time.midpointResidualTolerance: must be positive"),
])
def test_integrator_settings_are_checked(key, value, message):
    with pytest.raises(CaseError, match=message.replace("[", r"\[").replace(")", r"\)")):
        wcsph.case.config.load("hydrostatic_2d_bi", [(key, value)])


# ------------------------------------------------------------------ adaptive RK45
def test_rk45_error_control(smooth_reference, tmp_path):
    """With a variable step and a loose stability bound (cfl 2), RK45 picks the step from
    its error estimate: every accepted step's scaled error is within the tolerance, a
    tighter tolerance takes more steps, and the result is as accurate as asked."""
    steps, errors = [], []
    for tol in (1e-6, 1e-9):
        case = {"dim": 2, "dp": DP, "precision": "float64",
                "time": {"end": T_SMOOTH, "integrator": "rk45", "cfl": 2.0, "rk45_tolerance": tol},
                "physics": {"gravity": [0.0, 0.0], "speed_of_sound": 10.0},
                "model": {"name": "bi", "h": 1.9 * DP, "DiffusiveTerm": "None", "enableElasticBounce": False,
                          "enableNearBoundaryShifting": False},
                "domain": {"min": [-0.1, -0.1], "max": [0.2, 0.2]},
                "fluid": [{"min": [0.0, 0.0], "max": [0.1, 0.1]}], "output": {"progress": False, "vtk": False}}
        sim = wcsph.Simulation(validate(case))
        x = sim.host(sim.fluid, "x")[0]
        sim.fluid["v"] = np.stack([U * np.sin(2 * np.pi * x[1] / 0.1), U * np.cos(2 * np.pi * x[0] / 0.1)])
        # stepped here, the last step shortened onto T_SMOOTH (a run ends at the first step past
        # its end time); each step's error estimate as steps.csv records it
        while sim.t < T_SMOOTH * (1 - 1e-12):
            sim.step(min(sim.time_step(), T_SMOOTH - sim.t))
            assert sim.integrator.stats["rk_error"] <= tol
        ids, x, v, rho = sim.host(sim.fluid, "id", "x", "v", "rho")
        o = np.argsort(ids)
        steps.append(sim.steps)
        errors.append(_error((x[:, o], v[:, o], rho[o]), smooth_reference))
    print("RK45 steps", steps, "errors", errors)
    assert steps[1] > steps[0]
    assert errors[1] < errors[0] and errors[1] < 1e-6


def test_dt_min_stops_cleanly(tmp_path):
    """A step below time.dtMin stops the run with a message naming it, and the last good
    state written."""
    case = wcsph.case.config.load("hydrostatic_2d_bi", [("time.end", 0.01), ("dp", 0.05), ("time.dtMin", 1.0)])
    with pytest.raises(wcsph.SimulationError, match="dtMin"):
        wcsph.Simulation(case).run(tmp_path, progress=False)
    assert (tmp_path / "fluid_failed.vtu").exists()


# ------------------------------------------------------------------------------ registry
def test_readme_integrator_table_is_the_registry():
    """The README's integrator table is the second part of ``wcsph slots``."""
    from pathlib import Path

    from wcsph.physics.integrators import integrator_table

    text = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    a = text.index("<!-- integrator-table")
    assert text[text.index("\n", a) + 1:text.index("\n<!-- /integrator-table -->")] == integrator_table()


TOY_SCHEME = '''
from wcsph.physics.integrators import Integrator, make_symplectic_euler, register
from wcsph.physics.registry import Param, POS


@register
class ToyEuler(Integrator):
    name, spec_name, ref = "toy_euler", "ToyEulerScheme", "a test of the registry"
    params = (Param("toy_scale", 1.0, "a parameter of the toy scheme", check=POS, table="time"),)
    factory = staticmethod(make_symplectic_euler)
    order = 1

    def step(self, state, P):
        state.evaluate(P)
        self.maps[0](state.view(), P)
        return float(P.dt)
'''

RUN_TOY = '''
import json
import numpy as np
from wcsph import Simulation
from wcsph.case.config import load, validate
from wcsph.errors import CaseError
from wcsph.physics.integrators import integrator_table

def final(scheme, extra=()):
    case = load("dam_break_2d", [("dp", 0.02), ("time.max_steps", 20), ("time.dt", 2e-4),
                                 ("time.integrator", scheme)] + list(extra))
    sim = Simulation(case)
    sim.run()
    ids, x = sim.host(sim.fluid, "id", "x")
    return x[:, np.argsort(ids)]

toy = final("ToyEulerScheme", [("time.toy_scale", 2.0)])
ref = final("symplectic_euler")
try:
    load("dam_break_2d", [("time.toy_scale", -1.0)])
    bad = ""
except CaseError as e:
    bad = str(e)
print(json.dumps({"dx": float(np.abs(toy - ref).max()), "listed": "`toy_euler`" in integrator_table(), "bad": bad}))
'''


def test_a_new_integrator_is_one_class_plus_register(tmp_path):
    """A scheme in a plug-in module: its names and its parameter enter ``[time]`` (a bad
    value is refused with its key), it is listed, and it runs (here symplectic Euler again,
    so the positions are those of ``symplectic_euler`` bit for bit)."""
    import json
    import os
    import subprocess
    import sys

    (tmp_path / "toy_scheme.py").write_text(TOY_SCHEME)
    env = dict(os.environ, WCSPH_PLUGINS="toy_scheme",
               PYTHONPATH=os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-c", RUN_TOY], capture_output=True, text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["listed"] and out["dx"] == 0.0, out
    assert "time.toy_scale" in out["bad"] and "positive" in out["bad"], out
