"""Checkpoint and restart: a run stopped at a step and resumed from its checkpoint ends in
exactly the state of the run that never stopped (same backend and precision), for every
integrator; checkpoints of another case or format are refused with one clear line."""
import json

import numpy as np
import pytest

from wcsph import Simulation
from wcsph.cli import main
from wcsph.case.config import load
from wcsph.errors import CaseError

INTEGRATORS = ["symplectic_euler", "verlet", "symplectic_verlet", "rk4", "rk45", "midpoint"]


def _case(name, integrator, *extra):
    over = [("dp", 0.04 if name.endswith("_bi") else 0.05), ("time.end", 0.03), ("time.integrator", integrator),
            ("output.vtk", False), ("output.interval", 0.01), ("time.verlet_euler_interval", 4), *extra]
    return load(name, over)


@pytest.mark.parametrize("name,integrator", [("dam_break_2d_bi", i) for i in INTEGRATORS]
                         + [("dam_break_2d", "symplectic_euler")])
def test_restart_is_bit_for_bit(name, integrator, tmp_path):
    whole = Simulation(_case(name, integrator))
    whole.run(output=tmp_path / "whole", progress=False)
    meta_w, arrays_w = Simulation.read_checkpoint(tmp_path / "whole")

    first = Simulation(_case(name, integrator, ("time.max_steps", 7)))  # stops at a step boundary
    first.run(output=tmp_path / "split", progress=False)
    meta, arrays = Simulation.read_checkpoint(tmp_path / "split")
    assert meta["steps"] == 7 and meta["t"] < meta_w["t"]
    # a decomposed run's checkpoint lacks the spare arrays of symplectic Verlet's predictor
    # (``Integrator.fuse_first``): scratch, so only their size matters to the restart
    spares = [k for k in arrays if k.endswith("_spare")]
    assert bool(spares) == (integrator == "symplectic_verlet" and name.endswith("_bi"))
    arrays = {k: a for k, a in arrays.items() if k not in spares}
    second = Simulation(_case(name, integrator))
    second.restore(meta, arrays)
    second.run(output=tmp_path / "split", progress=False)
    meta_s, arrays_s = Simulation.read_checkpoint(tmp_path / "split")

    assert (meta_s["t"], meta_s["steps"]) == (meta_w["t"], meta_w["steps"])
    assert meta_s["integrator"]["carried"] == meta_w["integrator"]["carried"]
    assert set(arrays_s) == set(arrays_w)
    for k in ("x", "v", "rho", "id"):  # rho: summation density (classic) is recomputed, but saved too
        assert np.array_equal(arrays_s[k], arrays_w[k]), k
    # the series continues: one probes.csv row per output time, none twice
    times = [float(line.split(",")[0]) for line in (tmp_path / "split" / "probes.csv").read_text().splitlines()[1:]]
    assert times == sorted(set(times)) and times[-1] == pytest.approx(meta_w["t"])


def test_a_finished_run_extended_is_the_run_made_straight(tmp_path):
    """A run that reached its end time and is resumed to a later one ends bit for bit where a
    run straight to the later time ends (the last step is not shortened onto the first end
    time), with the same probes.csv rows and grid frames."""
    over = ["--dp", "0.04", "--no-progress", "--set", "output.vtk=false", "--set", "output.interval=0.01",
            "--set", 'grids=[{name = "g", origin = [0.1, 0.05], axes = [[0.2, 0.0]], counts = [5], interval = 0.02}]']
    assert main(["run", "dam_break_2d_bi", "-o", str(tmp_path / "ext"), "--end-time", "0.02", *over]) == 0
    first = json.loads((tmp_path / "ext" / "run.json").read_text())
    assert first["end_time"] >= 0.02
    assert main(["resume", str(tmp_path / "ext"), "--end-time", "0.05", "--no-progress"]) == 0
    assert main(["run", "dam_break_2d_bi", "-o", str(tmp_path / "straight"), "--end-time", "0.05", *over]) == 0
    meta_e, arrays_e = Simulation.read_checkpoint(tmp_path / "ext")
    meta_s, arrays_s = Simulation.read_checkpoint(tmp_path / "straight")
    assert (meta_e["t"], meta_e["steps"]) == (meta_s["t"], meta_s["steps"]) and meta_s["t"] >= 0.05
    for k in ("x", "v", "rho", "id"):
        assert np.array_equal(arrays_e[k], arrays_s[k]), k
    rows = [(tmp_path / d / "probes.csv").read_text().splitlines() for d in ("ext", "straight")]
    assert rows[0] == rows[1] and len(rows[0]) == 7  # header and t = 0, 0.01, ..., 0.05
    grids = [(tmp_path / d / "grid_g.pvd").read_text() for d in ("ext", "straight")]
    assert grids[0] == grids[1] and grids[0].count("<DataSet") == 3  # t = 0, 0.02, 0.04
    for k in range(3):
        assert (tmp_path / "ext" / f"grid_g_{k:04d}.vti").read_bytes() == (tmp_path / "straight" / f"grid_g_{k:04d}.vti").read_bytes()


def test_resume_drops_a_row_cut_short(tmp_path):
    """A kill (or a full disk) in the middle of a row leaves a last line without a line end:
    the resume drops it, and every row of the series is whole and in order."""
    out = tmp_path / "run"
    over = ["--no-progress", "--set", "output.vtk=false", "--set", "output.interval=0.01"]
    assert main(["run", "hydrostatic_2d", "-o", str(out), "--end-time", "0.02", *over]) == 0
    probes = out / "probes.csv"
    whole = probes.read_text()
    probes.write_text(whole + whole.splitlines()[-1][:-2])  # the last row again, cut in its last field
    assert main(["resume", str(out), "--end-time", "0.04", "--no-progress"]) == 0
    lines = probes.read_text().split("\n")
    assert lines[-1] == ""  # ends with a line end
    rows = [line.split(",") for line in lines[1:-1]]
    assert all(len(r) == len(lines[0].split(",")) for r in rows)
    t = [float(r[0]) for r in rows]
    assert t == sorted(set(t)) and len(t) == 5 and t[-1] >= 0.04


def test_resume_command_and_refusals(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "hydrostatic_2d", "-o", str(out), "--no-progress", "--end-time", "0.02",
                 "--set", "output.vtk=false"]) == 0
    assert main(["resume", str(out), "--end-time", "0.04", "--no-progress"]) == 0
    summary = json.loads((out / "run.json").read_text())
    assert summary["status"] == "completed" and 0.04 <= summary["end_time"] < 0.041  # one step past at most
    capsys.readouterr()
    assert main(["resume", str(out), "--no-progress"]) == 2  # already at its end time
    assert "give a later --end-time" in capsys.readouterr().err
    assert main(["resume", str(tmp_path / "nothing")]) == 2
    assert "no checkpoint" in capsys.readouterr().err
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a checkpoint")
    assert main(["resume", str(bad)]) == 2
    assert "not a readable wcsph checkpoint" in capsys.readouterr().err
    # a checkpoint of another case is refused
    meta, arrays = Simulation.read_checkpoint(out)
    other = Simulation(load("hydrostatic_2d", [("dp", 0.05)]))
    with pytest.raises(CaseError, match="another case or other settings"):
        other.restore(meta, arrays)


@pytest.mark.parametrize("name,extra", [
    ("poiseuille_open_2d", [("dp", 0.05), ("time.end", 0.15)]),
    ("moving_square_2d", [("dp", 0.1), ("model.shifting", "None"), ("time.end", 0.1)]),
    ("hydrostatic_2d_bi", [("dp", 0.05), ("time.end", 0.05),
                           ("obstacle", [{"name": "box", "min": [0.8, 0.3], "max": [1.2, 0.7],
                                         "floating": {"density": 700.0}}])])])
def test_restart_with_open_boundaries_and_moving_walls_is_bit_for_bit(name, extra, tmp_path):
    """Buffers that create and remove particles (their counters carried in the checkpoint),
    walls placed from a motion table, a floating body (its state carried): stopped at step 7
    and resumed, the same state as the run that did not stop."""
    def case(*more):
        return load(name, extra + [("output.vtk", False), ("output.interval", 0.05), *more])

    whole = Simulation(case())
    whole.run(output=tmp_path / "whole", progress=False)
    meta_w, arrays_w = Simulation.read_checkpoint(tmp_path / "whole")
    Simulation(case(("time.max_steps", 7))).run(output=tmp_path / "split", progress=False)
    meta, arrays = Simulation.read_checkpoint(tmp_path / "split")
    second = Simulation(case())
    second.restore(meta, arrays)
    second.run(output=tmp_path / "split", progress=False)
    meta_s, arrays_s = Simulation.read_checkpoint(tmp_path / "split")
    assert (meta_s["steps"], meta_s["n"]) == (meta_w["steps"], meta_w["n"])
    assert meta_s["open_boundary"] == meta_w["open_boundary"]
    if name.startswith("poiseuille"):
        assert meta_w["open_boundary"]["created"] > 0 and meta_w["open_boundary"]["removed"] > 0
    for k in ("x", "v", "rho", "id"):
        assert np.array_equal(arrays_s[k], arrays_w[k]), k
