"""Faults during a run: Ctrl-C, SIGTERM and kill -9 leave readable output; re-runs leave no
stale frames; the command line's small promises (--version, show, a closed pipe)."""
import json
import os
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import meshio
import pytest

from wcsph.cli import main

RUN = [sys.executable, "-m", "wcsph.cli", "run", "dam_break_2d", "--no-progress", "--dp", "0.01",
       "--set", "output.interval=1e-6"]  # a frame every step: kills land in writes


def _start(out):
    return subprocess.Popen(RUN + ["-o", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for_frames(out, count, proc, timeout=120):
    t0 = time.time()
    while time.time() - t0 < timeout:
        if len(list(out.glob("fluid_*.vtu"))) >= count:
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.05)
    raise AssertionError("no output frames appeared")


def _listed_frames_readable(out):
    """Every file a .pvd lists opens, and every .vtu in the directory is complete."""
    for pvd in ("fluid.pvd", "case.pvd"):
        if not (out / pvd).exists():
            continue
        root = ET.parse(out / pvd).getroot()
        for ds in root.iter("DataSet"):
            mesh = meshio.read(out / ds.get("file"))
            assert mesh.points.shape[0] > 0
    for f in out.glob("fluid_*.vtu"):  # a kill -9 may leave a hidden .tmp file, never these
        meshio.read(f)


@pytest.mark.parametrize("sig,name", [(signal.SIGINT, "SIGINT"), (signal.SIGTERM, "SIGTERM")])
def test_interrupt_stops_cleanly_with_the_state_written(tmp_path, sig, name):
    out = tmp_path / "run"
    proc = _start(out)
    _wait_for_frames(out, 2, proc)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("wcsph: interrupted:") and name in lines[0], stderr
    summary = json.loads((out / "run.json").read_text())
    assert summary["status"] == "interrupted" and summary["steps"] > 0
    _listed_frames_readable(out)
    # the state at the stop is the last frame of the series
    root = ET.parse(out / "fluid.pvd").getroot()
    last = list(root.iter("DataSet"))[-1]
    assert float(last.get("timestep")) == pytest.approx(summary["end_time"], rel=1e-6)


def test_kill_9_at_any_moment_leaves_every_listed_frame_readable(tmp_path):
    """SIGKILL at spread-out moments while frames are written every few steps."""
    for k, delay in enumerate((0.0, 0.13, 0.29, 0.41, 0.57)):
        out = tmp_path / f"run{k}"
        proc = _start(out)
        _wait_for_frames(out, 2, proc)
        time.sleep(delay)
        proc.kill()
        proc.wait()
        _listed_frames_readable(out)


def test_rerun_leaves_no_stale_frames(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    for name in ("fluid_0000.vtu", "fluid_0999.vtu", "fluid_failed.vtu"):
        (out / name).write_text("stale")
    assert main(["run", "hydrostatic_2d", "-o", str(out), "--no-progress", "--set", "time.max_steps=3"]) == 0
    listed = {ds.get("file") for ds in ET.parse(out / "fluid.pvd").getroot().iter("DataSet")}
    assert {f.name for f in out.glob("fluid_*.vtu")} == listed


def test_version_show_and_closed_pipe(capsys, tmp_path):
    from wcsph import __version__

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and __version__ in capsys.readouterr().out
    assert main(["show", "dam_break_2d"]) == 0
    shown = capsys.readouterr().out
    assert shown.startswith('name = "dam_break_2d"')
    case = tmp_path / "mine.toml"
    case.write_text(shown.replace('name = "dam_break_2d"', 'name = "mine"'))
    from wcsph.case.config import load

    assert load(str(case))["name"] == "mine"  # what show prints is a valid case
    assert main(["show", "no_such_case"]) == 2
    proc = subprocess.run(f"{sys.executable} -m wcsph.cli cases | head -1", shell=True, capture_output=True,
                          text=True, env=dict(os.environ))
    assert proc.stdout.count("\n") == 1 and "Traceback" not in proc.stderr and "Error" not in proc.stderr


# ------------------------------------------------------------------ bad input: one line, exit 2
BASE_TOML = """name = "x"
dim = 2
dp = 0.05
[[fluid]]
min = [0.0, 0.0]
max = [0.5, 0.5]
[tank]
min = [0.0, 0.0]
max = [1.0, 1.0]
[time]
end = 0.01
"""


@pytest.mark.parametrize("case_text,args,message", [
    (b"\xff\xfe" + BASE_TOML.encode(), [], "not UTF-8 text"),
    ("fluid = []\n" + BASE_TOML.split("[[fluid]]")[0] + "[time]\nend = 0.01\n", [], "fluid: no fluid block"),
    (BASE_TOML + "[[obstacle]]\nmin = [0.0, 0.0]\nmax = [0.6, 0.6]\n", [], "the obstacles cover all the fluid"),
    (BASE_TOML + "[[fluid]]\nmin = [0.2, 0.2]\nmax = [0.7, 0.7]\n", [], "fluid[1]: overlaps fluid[0] (in [0.2, 0.2]"),
    (BASE_TOML, ["--dp", "5e-6"], "--dp: 5e-06 m makes about"),
    (BASE_TOML, ["--set", "model.wall_layers=100000"], "GiB; this machine has"),
    (BASE_TOML, ["--backend", "cuda"], "backend: cuda: no usable NVIDIA GPU"),
    (BASE_TOML, ["-o", "FILE"], "is a file, not a directory"),
    (BASE_TOML, ["-o", "UNDER_FILE"], "cannot create"),
    (BASE_TOML, ["--set", "time.end=-1"], "--set time.end: must be positive, got -1"),
    (BASE_TOML.replace('name = "x"', 'name = "../../elsewhere"'), [], "name: must be letters, digits"),
    (BASE_TOML + '[[probes]]\nname = "time"\nkind = "level"\nposition = [0.2, 0.0]\n', [],
     "probes[0].name: the column 'time' of probes.csv would be written twice"),
    (BASE_TOML + '[[obstacle]]\nname = "box"\nmin = [0.7, 0.0]\nmax = [0.8, 0.1]\n'
     '[[probes]]\nname = "box_fx"\nkind = "pressure"\nposition = [0.2, 0.1]\n', [],
     "probes[0].name: the column 'box_fx' of probes.csv would be written twice"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, case_text, args, message):
    if "cuda" in args:
        from numba import cuda

        if cuda.is_available():
            pytest.skip("a GPU is present")
    path = tmp_path / "case.toml"
    path.write_bytes(case_text if isinstance(case_text, bytes) else case_text.encode())
    afile = tmp_path / "afile"
    afile.write_text("")
    args = [{"FILE": str(afile), "UNDER_FILE": str(afile / "sub")}.get(a, a) for a in args]
    if "-o" not in args:
        args += ["-o", str(tmp_path / "out")]
    assert main(["run", str(path), "--no-progress", *args]) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("wcsph: error: ") and message in lines[0], err
    assert "np.float64" not in err


@pytest.mark.parametrize("limit,message", [(50, " particles; the cpu backend addresses at most 50."),
                                           (500, " cells; the cpu backend addresses at most 500.")])
def test_a_case_beyond_the_backends_indices_is_one_line(tmp_path, capsys, monkeypatch, limit, message):
    """The GPU's sort indexes particles and cells with 32 bits (``cuda.INDEX``): a case with
    more is refused before any allocation, as here the CPU backend with a lowered limit (the
    case: 100 fluid and 272 wall particles, 772 grid cells)."""
    from wcsph.backends.cpu import CpuBackend

    monkeypatch.setattr(CpuBackend, "max_index", limit)
    path = tmp_path / "case.toml"
    path.write_text(BASE_TOML)
    assert main(["run", str(path), "--no-progress", "-o", str(tmp_path / "out")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "dp: 0.05 m makes" in lines[0], lines


def test_all_particles_leaving_the_domain_stops_cleanly(tmp_path, capsys):
    case = tmp_path / "jet.toml"
    case.write_text('name = "jet"\ndim = 2\ndp = 0.05\n[[fluid]]\nmin = [0.0, 0.0]\nmax = [0.3, 0.3]\n'
                    "velocity = [40.0, 0.0]\n[domain]\nmin = [-0.1, -0.1]\nmax = [0.5, 0.5]\n"
                    "[physics]\ngravity = [0.0, 0.0]\nspeed_of_sound = 400.0\n[time]\nend = 0.05\n"
                    "[output]\nsurge_front = true\n")
    assert main(["run", str(case), "--no-progress", "-o", str(tmp_path / "out")]) == 3
    err = capsys.readouterr().err
    assert "every fluid particle has left the domain" in err and "Traceback" not in err


# ------------------------------------------------------------------ defaults that run
def test_each_integrator_starts_from_its_own_safe_cfl(capsys, tmp_path):
    from wcsph import Simulation
    from wcsph.case.config import load

    expected = {"symplectic_euler": 0.025, "verlet": 0.05, "symplectic_verlet": 0.25, "rk4": 0.5,
                "rk45": 0.5, "midpoint": 0.5}
    for name, cfl in expected.items():
        sim = Simulation(load("dam_break_2d_bi", [("dp", 0.05), ("time.integrator", name)]))
        assert sim.cfl == cfl and not sim.warnings, name
    assert Simulation(load("hydrostatic_2d", [("dp", 0.05)])).cfl == 0.25  # summation density
    # the example: Verlet on the WCSPH-BI dam break, cfl left to the scheme, runs
    assert main(["run", "dam_break_2d_bi", "--dp", "0.02", "--end-time", "0.3", "--no-progress", "-o",
                 str(tmp_path / "v"), "--set", "time.integrator=verlet", "--set", "output.vtk=false"]) == 0
    # a cfl past the measured limit runs, with one warning line
    assert main(["run", "dam_break_2d_bi", "--dp", "0.04", "--end-time", "0.002", "--no-progress", "-o",
                 str(tmp_path / "w"), "--set", "time.integrator=verlet", "--set", "time.cfl=0.25"]) == 0
    err = capsys.readouterr().err
    assert err.count("wcsph: warning: time.cfl = 0.25 is past the largest stable value") == 1


def test_probes_at_their_own_rate(tmp_path):
    """probe_interval samples probes.csv independently of the VTK frames (TNL-SPH's
    sensor output time): 1 ms rows between frames 10 ms apart."""
    import csv

    out = tmp_path / "run"
    assert main(["run", "dam_break_2d_bi", "--dp", "0.02", "--end-time", "0.02", "--no-progress", "-o", str(out),
                 "--set", "output.interval=0.01", "--set", "output.probe_interval=0.001"]) == 0
    with open(out / "probes.csv") as f:
        rows = list(csv.DictReader(f))
    t = [float(r["time"]) for r in rows]
    dt = max(float(r["dt"]) for r in rows)
    assert 19 <= len(rows) <= 22 and t == sorted(t)
    gaps = [b - a for a, b in zip(t, t[1:])]
    assert all(0.001 - dt - 1e-9 <= g <= 0.001 + dt + 1e-9 for g in gaps[:-1]), gaps
    frames = [ds.get("file") for ds in ET.parse(out / "fluid.pvd").getroot().iter("DataSet")]
    assert len(frames) == 3  # t = 0, 0.01, 0.02


def test_plot_writes_pngs_of_the_probe_series(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "dam_break_2d_bi", "--dp", "0.04", "--end-time", "0.01", "--no-progress", "-o", str(out),
                 "--set", "output.vtk=false"]) == 0
    capsys.readouterr()
    assert main(["plot", str(out)]) == 0
    written = capsys.readouterr().out.split()
    names = {p.rsplit("/", 1)[1] for p in written}
    assert {"plot_energies.png", "plot_pressure.png", "plot_levels.png", "plot_surge_front.png"} <= names
    for p in written:
        assert open(p, "rb").read(8) == b"\x89PNG\r\n\x1a\n"
    assert main(["plot", str(tmp_path / "nothing")]) == 2


def test_full_disk_stops_with_one_line_and_whole_files(tmp_path, capsys):
    """A small tmpfs fills up mid-run (needs the right to mount, else skipped)."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", str(mnt)], capture_output=True).returncode:
        pytest.skip("cannot mount a small filesystem here")
    try:
        out = mnt / "run"
        rc = main(["run", "dam_break_2d", "--dp", "0.02", "--end-time", "0.2", "--no-progress", "-o", str(out)])
        err = capsys.readouterr().err
        assert rc == 4 and err.startswith("wcsph: output error: ") and "No space left on device" in err
        assert len(err.strip().splitlines()) == 1
        _listed_frames_readable(out)
        assert not list(out.glob(".*.tmp*"))
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)
