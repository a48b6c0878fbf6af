"""Case validation, the command line and its output files."""
import json
import os
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

from wcsph.cli import main
from wcsph.case.config import load, shipped_cases, validate
from wcsph.errors import CaseError

BASE = {
    "dim": 2, "dp": 0.05,
    "fluid": [{"min": [0.0, 0.0], "max": [0.5, 0.5]}],
    "tank": {"min": [0.0, 0.0], "max": [1.0, 1.0]},
    "time": {"end": 0.01},
}


def _case(**changes):
    import copy

    d = copy.deepcopy(BASE)
    for key, value in changes.items():
        node = d
        *path, last = key.split("__")
        for p in path:
            node = node[p] if not p.isdigit() else node[int(p)]
        node[last] = value
    return d


@pytest.mark.parametrize("changes,message", [
    ({"dpp": 0.1}, "dpp: unknown key"),
    ({"model": {"xsph": "high"}}, "model.xsph: must be one of 'None', 'momentum', 'position', got 'high'"),
    ({"dp": -0.01}, "dp: must be positive"),
    ({"dp": 0}, "dp: must be positive"),
    ({"dim": 4}, "dim: must be 2 or 3"),
    ({"fluid__0__max": [0.5]}, "fluid[0].max: expected 2 components"),
    ({"fluid__0__max": [-0.5, 0.5]}, "fluid[0].max: must exceed fluid[0].min on axis 0"),
    ({"fluid__0__max": [1.5, 0.5]}, "fluid[0]: block reaches into the tank wall on axis 0"),
    ({"domain": {"min": [0.0, 0.0], "max": [0.3, 2.0]}}, "fluid: "),
    ({"time": {}}, "time.end: missing (required)"),
    ({"model": {"kernel": "gauss"}}, "model.kernel: must be one of"),
    ({"physics": {"kappa": 100.0, "speed_of_sound": 10.0}}, "physics.kappa: give kappa or speed_of_sound"),
])
def test_bad_input_names_the_key(changes, message):
    from wcsph import Simulation

    with pytest.raises(CaseError) as err:
        Simulation(validate(_case(**changes), src="case.toml"))
    assert str(err.value).startswith("case.toml: ")
    assert message in str(err.value)


def test_outside_domain_message():
    from wcsph import Simulation

    with pytest.raises(CaseError, match="fluid particles lie outside the domain"):
        Simulation(validate(_case(domain={"min": [0.0, 0.0], "max": [0.3, 2.0]}), src="c.toml"))


def test_shipped_cases_validate():
    assert {"dam_break_2d", "dam_break_3d", "hydrostatic_2d"} <= set(shipped_cases())
    for name in shipped_cases():
        case = load(name)
        assert case["dim"] in (2, 3)


def test_set_overrides_by_dotted_key():
    case = load("dam_break_2d", [("model.xsph_epsilon", 0.05), ("dp", 0.04), ("time.end", 0.5)])
    assert case["model"]["xsph_epsilon"] == 0.05 and case["dp"] == 0.04 and case["time"]["end"] == 0.5
    with pytest.raises(CaseError, match="model.nope: unknown key"):
        load("dam_break_2d", [("model.nope", 1)])


def test_a_renamed_key_names_its_new_name():
    with pytest.raises(CaseError, match="model.enableShifting: renamed: write model.enableNearBoundaryShifting"):
        load("dam_break_2d_bi", [("model.enableShifting", False)])


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "wcsph.cli", *args], capture_output=True, text=True,
                          cwd=cwd, env=dict(os.environ, PYTHONUNBUFFERED="1"))


def test_cli_bad_input_one_line_exit_2(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('dim = 2\ndp = -0.1\n[[fluid]]\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]\n[time]\nend = 1.0\n')
    r = _cli("run", str(bad), "-o", str(tmp_path / "o"))
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines() == [f"wcsph: error: {bad}: dp: must be positive, got -0.1"]
    r = _cli("run", "dam_break_2d", "--set", "model.bogus=1")
    assert r.returncode == 2 and "model.bogus: unknown key" in r.stderr and "Traceback" not in r.stderr
    r = _cli("run", "no_such_case")
    assert r.returncode == 2 and "no_such_case" in r.stderr


def test_cli_runs_a_case_and_writes_outputs(tmp_path):
    out = tmp_path / "run"
    r = _cli("run", "dam_break_2d", "--dp", "0.05", "--end-time", "0.05", "-o", str(out),
             "--set", "output.interval=0.025")
    assert r.returncode == 0, r.stderr
    summary = json.loads((out / "run.json").read_text())
    for key in ("dim", "dp", "n_fluid", "n_boundary", "steps", "wall_time_s", "particle_steps_per_s",
                "compile_time_s"):
        assert key in summary
    assert summary["dim"] == 2 and summary["dp"] == 0.05 and summary["n_fluid"] == 20 * 40
    assert summary["steps"] > 10 and summary["particle_steps_per_s"] > 0
    assert summary["checks_read_every"] == 1  # the CPU's checks are on the host each step
    vtus = sorted(out.glob("fluid_*.vtu"))
    assert len(vtus) == 3  # t = 0, 0.025, 0.05
    mesh = meshio.read(vtus[-1])
    assert {"rho", "p", "v"} <= set(mesh.point_data)
    assert mesh.points.shape == (800, 3)
    rho = mesh.point_data["rho"]
    # a free-surface corner particle sees about a quarter of a neighbourhood
    assert rho.min() > 0.3 * 1000 and 1000 < rho.max() < 1100
    assert meshio.read(out / "walls.vtu").points.shape[0] == summary["n_boundary"]
    pvd = (out / "fluid.pvd").read_text()
    assert pvd.count("<DataSet") == 3 and "fluid_0002.vtu" in pvd
    lines = (out / "probes.csv").read_text().splitlines()
    assert lines[0].split(",")[:6] == ["time", "step", "dt", "n_fluid", "kinetic_energy", "potential_energy"]
    assert "surge_front" in lines[0] and len(lines) == 4
    # the plain (non-terminal) progress display prints lines with steps/s
    assert "steps/s" in r.stderr


def test_cli_lists_cases():
    r = _cli("cases")
    assert r.returncode == 0 and "dam_break_2d" in r.stdout and "hydrostatic_2d" in r.stdout


def test_blow_up_stops_cleanly(tmp_path):
    """A time step far past the CFL limit blows up: exit 3, a message, the last good state."""
    out = tmp_path / "blow"
    r = _cli("run", "dam_break_2d", "--dp", "0.05", "--end-time", "0.5", "-o", str(out),
             "--set", "time.dt=0.01", "--set", "output.interval=0.01", "--no-progress")
    assert r.returncode == 3, r.stdout + r.stderr
    assert "Traceback" not in r.stderr
    assert "run stopped" in r.stderr and "last good output" in r.stderr
    assert (out / "fluid_failed.vtu").exists() and (out / "fluid_0000.vtu").exists()
    assert json.loads((out / "run.json").read_text())["status"] == "failed"


def test_kappa_sets_the_sound_speed():
    from wcsph import Simulation

    sim = Simulation(validate(_case(physics={"kappa": 400.0}), src="c.toml"))
    assert sim.c0 == 20.0
    assert sim.P.eos_b == np.float32(400.0 * 1000.0 / 7.0)


def test_obstacle_displaces_fluid_and_is_sampled_as_walls():
    """A box obstacle inside a fluid block: its walls are sampled, the fluid it overlaps is
    removed with a gap of dp/2, and the case runs. (With gravity ramped on: the column is
    sampled on the plain lattice, which the obstacle's faces lie on.)"""
    from wcsph import Simulation

    obstacle = {"min": [0.2, 0.0], "max": [0.3, 0.2]}
    case = validate(_case(obstacle=[obstacle], fluid=[{"min": [0.0, 0.0], "max": [0.5, 0.4]}],
                          physics={"gravity_ramp_time": 0.05}), src="c.toml")
    without = Simulation(validate(_case(fluid=[{"min": [0.0, 0.0], "max": [0.5, 0.4]}],
                                        physics={"gravity_ramp_time": 0.05}), src="c.toml"))
    sim = Simulation(case)
    x = sim.host(sim.fluid, "x")[0]
    inside = (x[0] > 0.2 - 0.5 * 0.05) & (x[0] < 0.3 + 0.5 * 0.05) & (x[1] < 0.2 + 0.5 * 0.05)
    assert not inside.any()
    assert sim.fluid.n == without.fluid.n - 2 * 4  # a 2 x 4 block of the lattice is displaced
    assert sim.walls.n == without.walls.n + 2 * 4  # the 0.1 x 0.2 box, full of wall particles
    sim.run(progress=False)
    assert sim.dropped == 0
