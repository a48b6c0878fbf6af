"""The CUDA kernels, run in Numba's CUDA simulator, reproduce the CPU backend."""
import json
import os
import subprocess
import sys

import pytest

pytest.importorskip("numba.cuda")

#: ``WCSPH_CUDA_DEVICE=1`` runs these comparisons on the machine's GPU instead of the simulator
#: (``benchmarks/device_check.sh``, for a session that is lent one)
ON_DEVICE = os.environ.get("WCSPH_CUDA_DEVICE") == "1"


def _env():
    """The subprocess's environment: Numba's CUDA simulator, or the GPU with ``ON_DEVICE``."""
    if ON_DEVICE:
        return {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    return dict(os.environ, NUMBA_ENABLE_CUDASIM="1")


#: the simulator runs each thread of a block as a Python thread: blocks of 32 (not 128) make
#: its launches 2-3 times faster, and the kernels are written for any block size
FAST_SIMULATOR = "import wcsph.backends.cuda as cb; cb.THREADS = 32\n"

SCRIPT = FAST_SIMULATOR + r"""
import json, sys, numpy as np, wcsph
from wcsph.case.config import load
name, dp, extra = sys.argv[1], float(sys.argv[2]), json.loads(sys.argv[3])
res = {}
for be in ("cpu", "cuda"):
    case = load(name, [("dp", dp), ("time.max_steps", 4), ("time.dt", 5e-4), ("precision", "float64")] + list(extra.items()))
    sim = wcsph.Simulation(case, backend=be)
    sim.run(progress=False)
    x, v, rho, p, ids = sim.host(sim.fluid, "x", "v", "rho", "p", "id")
    o = np.argsort(ids)
    res[be] = (x[:, o], v[:, o], rho[o], p[o], sim.fluid.n, sim.steps)
c, g = res["cpu"], res["cuda"]
print(json.dumps({"n": [c[4], g[4]], "steps": [c[5], g[5]],
                  "dx": float(np.abs(c[0] - g[0]).max()), "dv": float(np.abs(c[1] - g[1]).max()),
                  "drho": float(np.abs(c[2] - g[2]).max()), "dp": float(np.abs(c[3] - g[3]).max()),
                  "vmax": float(np.abs(c[1]).max()), "pmax": float(np.abs(c[3]).max())}))
"""


#: simulator cases run with ``-m validation`` only: 10-35 s each cold, and the default suite
#: must stay within ten minutes on a cold two-core machine
SLOW = {"classic-3d", "bi-2d-midpoint", "bi-2d-rk45", "classic-2d-verlet", "bi-2d-corrections",
        "classic-2d-corrections", "bi-2d-open", "bi-2d-floating", "classic-2d-floating", "bi-2d-wall-law", "bi-2d-sps"}


CASES = [
    ("classic-2d", "dam_break_2d", 0.1, {}), ("classic-3d", "dam_break_3d", 0.06, {}),
    # 3D at dp 0.08 and two steps: the same loops as at 0.06 over four, at a quarter of the
    # simulator time (the second step sorts with the check's cell counts)
    ("bi-2d", "dam_break_2d_bi", 0.05, {}), ("bi-3d", "dam_break_3d_bi", 0.08, {"time.max_steps": 2}),
    ("bi-2d-midpoint", "dam_break_2d_bi", 0.05, {"time.integrator": "midpoint", "time.midpointMaxInterations": 4}),
    ("bi-2d-rk45", "dam_break_2d_bi", 0.05, {"time.integrator": "rk45"}),
    ("classic-2d-verlet", "dam_break_2d", 0.1, {"time.integrator": "verlet"}),
    ("bi-2d-corrections", "dam_break_2d_bi", 0.05, {
        "model.kernel_correction": "CSPM", "model.collision": "DPC", "model.shifting": "DeltaPlus",
        "model.xsph": "position", "model.pressure": "Monaghan1992ArtificialViscosity"}),
    ("classic-2d-corrections", "dam_break_2d", 0.1, {
        "model.kernel_correction": "CSPM", "model.collision": "DPC", "model.shifting": "Lind",
        "model.density": "continuity", "model.DiffusiveTerm": "MolteniDiffusiveTerm", "model.cspm_density_interval": 2}),
    ("bi-2d-periodic-moving", "couette_2d", 5e-5, {"time.dt": 1e-3}),
    # the turbulent wall law (y+ up to about 300 here: the law, not its no-slip branch)
    ("bi-2d-wall-law", "dam_break_2d_bi", 0.05, {"model.wall_law": "werner-wengle", "time.dt": 0.002}),
    ("bi-2d-open", "poiseuille_open_2d", 0.05, {"time.dt": 0.004, "time.max_steps": 8}),
    # the sub-particle-scale stress: a fluid pass before the interaction, a matrix field
    ("bi-2d-sps", "dam_break_2d_bi", 0.05, {"model.ViscousTerm": "LaminarSPS", "model.dynamicViscosity": 1e-3}),
    ("bi-2d-floating", "hydrostatic_2d_bi", 0.1, {"obstacle": [{"name": "box", "min": [0.8, 0.3], "max": [1.2, 0.7],
                                                               "floating": {"density": 700.0}}]}),
    # boundary particles: the loads' wall passes and load pass over the body's points only
    ("classic-2d-floating", "hydrostatic_2d", 0.08, {"obstacle": [{"name": "box", "min": [0.3, 0.3], "max": [0.7, 0.7],
                                                                "floating": {"density": 700.0}}],
                                                   "model.wall_velocity": "adami", "physics.gravity_ramp_time": 0.0}),
]


@pytest.mark.parametrize("name,dp,extra", [
    pytest.param(name, dp, extra, id=cid, marks=[pytest.mark.validation] if cid in SLOW else [])
    for cid, name, dp, extra in CASES])
def test_cuda_kernels_match_cpu_in_simulator(name, dp, extra):
    """Classic and WCSPH-BI (consistent scheme: boundary pass, interaction, wall corrections,
    symplectic Verlet), 2D and 3D; the implicit midpoint (with its residual reduction), RK45
    and Verlet; the correction toolbox (CSPM with its density re-initialisation, DPC,
    shifting, XSPH on the positions, Monaghan's Pi) in both models; the periodic walk with a
    moving wall (Couette) and the open-boundary buffers, whose particles enter the fluid and are
    created within the run; a floating body in each model (its loads summed on the device each
    step, over its own wall points only)."""
    env = _env()
    r = subprocess.run([sys.executable, "-c", SCRIPT, name, str(dp), json.dumps(extra)], capture_output=True, text=True,
                       env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    assert res["n"][0] == res["n"][1] and res["n"][0] > 50
    assert res["steps"] == [extra.get("time.max_steps", 4)] * 2
    assert res["vmax"] > 0 and res["pmax"] > 0  # something happened
    assert res["dx"] < 1e-12 and res["dv"] < 1e-10
    assert res["drho"] < 1e-9 and res["dp"] < 1e-6 * res["pmax"] + 1e-9


SORT_SCRIPT = r"""
import numpy as np
from numba import cuda
from wcsph.backends import cuda as cb
rng = np.random.default_rng(1)
work = {}
def check_sort(n, nc):
    cell = rng.integers(0, nc + 1, n).astype(np.int64)
    perm, start = cb._counting_sort(cuda.to_device(cell), nc, work)
    ref = np.argsort(cell, kind="stable")
    assert np.array_equal(perm.copy_to_host(), ref), (n, nc)
    assert np.array_equal(start.copy_to_host(), np.searchsorted(cell[ref], np.arange(nc + 2))), (n, nc)
for n, nc in [(0, 5), (1, 3), (400, 150), (400, 150)]:  # the last reuses the buffers
    check_sort(n, nc)
cb.SCAN_CHUNK, cb.SCAN_CHUNKS = 2, 300  # chunks longer than the shortest, over two blocks of the scan
work = {}
for n, nc in [(3000, 1000), (3000, 1000)]:
    check_sort(n, nc)
a = rng.normal(size=(3, 300))  # three blocks and the final one (the simulator runs barriers slowly)
mask = (rng.random(300) > 0.5).astype(np.int64)
for owned, sel in ((None, slice(None)), (cuda.to_device(mask), mask > 0), (None, slice(None))):
    got = cb._reduce_rows(cuda.to_device(a), ("sum", "max", "sum"), owned)
    want = (a[0][sel].sum(), a[1][sel].max(), a[2][sel].sum())
    assert np.allclose(got, want, rtol=1e-13, atol=1e-12), (got, want)
print("ok")
"""


def test_device_counting_sort_and_reduction_in_simulator():
    """The device sort (histogram, scan, scatter, each particle placed in its cell's stable
    order) gives exactly the CPU's stable
    argsort and cell starts, buffers reused or not; the block reduction gives numpy's sums and
    maxima, over all columns or the owned ones."""
    env = _env()
    r = subprocess.run([sys.executable, "-c", SORT_SCRIPT], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0 and r.stdout.strip().endswith("ok"), r.stderr[-3000:]


CHECKED_SORT = FAST_SIMULATOR + r"""
import numpy as np
from wcsph.backends.cpu import CpuBackend
from wcsph.backends.cuda import CudaBackend
from wcsph.backends.grid import Grid
from wcsph.backends.particles import ParticleSet
rng = np.random.default_rng(2)
grid = Grid.covering([0.0, 0.0], [1.0, 1.0], 0.2)
sets = {}
for name, be in (("cpu", CpuBackend()), ("cuda", CudaBackend())):
    x = rng.uniform(-0.05, 1.05, (2, 300))  # some outside the grid's inner cells
    sets[name] = (be, ParticleSet("fluid", 2, {"x": be.to_device(x), "v": be.to_device(np.zeros_like(x)),
                                               "dvdt": be.to_device(np.zeros_like(x)),
                                               "id": be.to_device(np.arange(300))}))
def same(tag):
    (cb, c), (gb, g) = sets["cpu"], sets["cuda"]
    for k in ("x", "id", "cell", "start"):
        assert np.array_equal(cb.to_host(c[k]), gb.to_host(g[k])), (tag, k)
    assert c.n == g.n, tag
def both(fn):
    for be, ps in sets.values():
        fn(be, ps)
x0 = rng.uniform(0.0, 1.0, (2, 300))
both(lambda be, ps: ps.arrays.__setitem__("x", be.to_device(x0)))
both(lambda be, ps: be.sort(ps, grid)); same("first sort")
both(lambda be, ps: be.check(ps)); both(lambda be, ps: be.sort(ps, grid)); same("counted by the check")
x1 = rng.uniform(-0.1, 1.1, (2, 300))  # moved after the check: its counts are stale
both(lambda be, ps: be.check(ps))
both(lambda be, ps: ps.arrays.__setitem__("x", be.to_device(x1[:, be.to_host(ps["id"])])))
both(lambda be, ps: be.sort(ps, grid)); same("moved after the check")
both(lambda be, ps: be.check(ps)); both(lambda be, ps: be.sort(ps, grid)); same("check again")
both(lambda be, ps: be.check(ps))
drop = (np.arange(sets["cpu"][1].n) % 7 == 0).astype(np.uint8)
both(lambda be, ps: be.sort(ps, grid, drop=be.to_device(drop))); same("dropped after a check")
both(lambda be, ps: be.check(ps)); both(lambda be, ps: be.sort(ps, grid)); same("after the drop")
print("ok")
"""


def test_a_sort_after_the_check_uses_its_cell_counts():
    """The check counts the next sort's cells: a sort of the checked positions uses them; a
    sort after the positions were replaced, or with particles to drop, counts afresh and
    leaves no stale count behind. Each gives the CPU backend's order, cells and starts."""
    r = subprocess.run([sys.executable, "-c", CHECKED_SORT], capture_output=True, text=True, env=_env(), timeout=600)
    assert r.returncode == 0 and r.stdout.strip().endswith("ok"), r.stderr[-3000:]


COUNTS = os.path.join(os.path.dirname(__file__), "..", "..", "benchmarks", "cuda_counts.py")


@pytest.mark.parametrize("name,dp,launches,scalars", [("dam_break_2d_bi", 0.05, 8, 1470), ("dam_break_2d", 0.1, 7, 1150)])
def test_a_cuda_step_reads_the_device_once_per_check_interval(name, dp, launches, scalars):
    """Counted in the simulator (``benchmarks/cuda_counts.py``) over four steps after the
    warm-up, with the adaptive time step and ``time.check_interval = 4``: one device-to-host
    copy in the four (the ring of the checks, each reduced straight into its row; each step's
    size is made on the device from the check before it, ``solver.timestep``), queued on the
    run's stream into pinned memory and verified a read later (the host waits for no launch
    it has just queued), no allocation, no copy on the device, and no upload: the step's
    parameters ``P`` are one device record that every launch reads instead of ~40 numbers by
    value, the same each step (its dt and the fields made from it written there by the
    device).
    Launches are held at today's count: the sort three (the scan, with the step's size made
    by its first thread; the scatter; and one launch that puts each particle at its place in
    its cell's stable order, moves every field there and, with a continuity density, makes p
    and V of the step's first evaluation; the cell ids, their histogram and the chunk sums
    the scan starts from are counted by the check of the step before), the model's passes
    and the integrator's maps, the last of which runs the wall corrections and the check in
    its own launch (``make_tail``): the classic model's three passes and one map, 7 in all;
    WCSPH-BI's two passes per evaluation, two evaluations (the first's interaction with the
    predictor and the EOS of the second in its loop, ``fuse_first``) and the corrector (with
    the elastic bounce and the check), 8. The scalars numba-cuda's dispatcher converts for
    their arguments are held too (a WCSPH-BI step: 1,648 with P by value, 1,444 with P as one
    record, 1,469 with the sizing's arguments; the classic 1,258, 1,122 and 1,147)."""
    r = subprocess.run([sys.executable, COUNTS, name, "--dp", str(dp), "--steps", "4", "--threads", "32", "--json",
                        "--set", "time.check_interval=4"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    c = json.loads(r.stdout.strip().splitlines()[-1])
    assert c["fluid"] > 50
    assert c.get("device->host copy", 0) == 0.25, c
    assert c.get("allocation", 0) == 0 and c.get("host->device copy", 0) == 0, c
    assert c.get("device->device copy", 0) == 0, c  # each check reduced straight into its row of the ring
    # every launch and copy on the run's own stream; the ring's copy is asynchronous, and the
    # host never waits for the queue it has just filled (at most for the copy a read before)
    assert c.get("launch off the stream", 0) == 0 and c.get("host waits for the queue", 0) == 0, c
    assert c.get("host waits for an earlier copy", 0) <= 0.25, c
    assert c["launches"] == launches, c
    assert c["kernel arguments"] <= scalars, c


@pytest.mark.validation
def test_a_floating_body_reads_its_loads_as_sums():
    """``floating_box_2d`` counted in the simulator: the body's force and torque are summed on
    the device (``backend.body_sums``), so a step copies two small arrays to the host (the
    sums and the check), not the walls' loads, positions and body ids (four copies before)."""
    r = subprocess.run([sys.executable, COUNTS, "floating_box_2d", "--dp", "0.1", "--steps", "2", "--threads", "32",
                        "--json"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    c = json.loads(r.stdout.strip().splitlines()[-1])
    assert c.get("device->host copy", 0) == 2 and c.get("allocation", 0) == 0, c
    assert c.get("launch off the stream", 0) == 0, c


def test_moving_walls_are_sorted_without_reading_their_count():
    """``couette_2d`` (its plate moving along the periodic axis) counted in the simulator:
    the moving walls' sort reads no count back where their bounds (``Bodies.bounds``) lie
    inside the grid, so the step's one copy to the host is its check (the step's size is
    made on the host with walls on a prescribed path); three before. (``moving_square_2d``
    counts the same, 4,900 particles at its coarsest: minutes in the simulator.)"""
    for name, dp in (("couette_2d", 5e-5),):
        r = subprocess.run([sys.executable, COUNTS, name, "--dp", str(dp), "--steps", "1", "--threads", "32",
                            "--json"], capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr[-3000:]
        c = json.loads(r.stdout.strip().splitlines()[-1])
        assert c.get("device->host copy", 0) == 1 and c.get("allocation", 0) == 0, (name, c)
        assert c.get("launch off the stream", 0) == 0, (name, c)


LEAVING = FAST_SIMULATOR + r"""
import json, numpy as np, wcsph
from wcsph.case.config import validate
res = {}
for be in ("cpu", "cuda"):
    case = validate({"name": "leaving", "dim": 2, "dp": 0.1, "precision": "float64",
                     "fluid": [{"min": [0.1, 0.0], "max": [0.6, 0.5], "velocity": ["30.0", "0.0"]}],
                     "domain": {"min": [-0.2, -0.2], "max": [0.6, 0.7]}, "model": {"name": "bi"},
                     "physics": {"gravity": [0.0, -9.81], "speed_of_sound": 100.0},
                     "time": {"end": 1.0, "max_steps": 8}, "output": {"progress": False}})
    sim = wcsph.Simulation(case, backend=be)
    sim.run()
    x, ids = sim.host(sim.fluid, "x", "id")
    res[be] = (x[:, np.argsort(ids)], sim.fluid.n, sim.dropped, sim.t)
c, g = res["cpu"], res["cuda"]
print(json.dumps({"n": [c[1], g[1]], "dropped": [c[2], g[2]], "t": [c[3], g[3]],
                  "dx": float(np.abs(c[0] - g[0]).max()) if c[1] == g[1] else None}))
"""


def test_particles_leaving_the_domain_on_the_device():
    """A block thrown out of the domain at 30 m/s, adaptive time step (five particles leave at
    the sixth of eight steps): the device drops the same particles as the CPU (parked beyond
    the grid until the host reads the checks, out of the speeds the next steps are sized
    from), the steps and the time are the CPU's, and the survivors are where the CPU's are."""
    env = _env()
    r = subprocess.run([sys.executable, "-c", LEAVING], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    assert res["dropped"][0] == res["dropped"][1] > 0 and res["n"][0] == res["n"][1], res
    assert res["t"][0] == res["t"][1] and res["dx"] < 1e-12, res


def test_cuda_matches_cpu_in_float32_with_the_adaptive_step():
    """``dam_break_2d_bi`` in float32 with the adaptive time step (sized on the device from its
    check, which the host reads every ten steps): the device's positions, velocities, densities and pressures are
    the CPU's to a few units of float32's last place (measured: 1e-8 m, 1e-5 of the largest
    speed, 2e-7 of the density, 2e-5 of the largest pressure), and the steps are the same."""
    env = _env()
    extra = {"precision": "float32", "time.dt": 0.0}
    r = subprocess.run([sys.executable, "-c", SCRIPT, "dam_break_2d_bi", "0.05", json.dumps(extra)], capture_output=True,
                       text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    assert res["n"][0] == res["n"][1] and res["steps"] == [4, 4]
    assert res["vmax"] > 0 and res["pmax"] > 0
    assert res["dx"] < 1e-6 and res["dv"] < 1e-4 * res["vmax"]
    assert res["drho"] < 2e-6 * 1000.0 and res["dp"] < 1e-4 * res["pmax"]


GPU_BENCH = os.path.join(os.path.dirname(__file__), "..", "..", "benchmarks", "gpu.py")


def test_the_gpu_benchmark_runs_and_counts_in_the_simulator():
    """``benchmarks/gpu.py`` (the table issue 21 asks for, ready for the day a GPU is lent),
    scaled down to 200 particles in the simulator: it sets the case up at its particle count,
    and its launch and synchronisation counts are those of ``cuda_counts.py``: 8 launches per
    step of the 2D WCSPH-BI dam break, and at a constant step (``--constant-dt``, as TNL-SPH
    runs) one device-to-host copy per ten steps (as at the adaptive step, sized on the device
    in the sort's first launch: ``test_a_cuda_step_reads_the_device_once_per_check_interval``)."""
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    r = subprocess.run([sys.executable, GPU_BENCH, "--cases", "2d-100k", "--scale", "0.002", "--warmup", "2",
                        "--count", "10", "--steps", "1", "--windows", "1", "--threads", "32", "--json",
                        "--constant-dt"], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    assert 150 <= res["fluid"] <= 250, res
    assert res["check_every"] == 10 and res["launches"] == 8 and res["syncs"] == 0.1, res
    assert res["ms_per_step"] > 0 and res["M_per_s"] > 0, res


#: the simulator's copies to the host counted in ``copies[0]``
COUNT_COPIES = r"""
from numba.cuda.simulator.cudadrv import devicearray
copies = [0]
original = devicearray.FakeCUDAArray.copy_to_host
def counted(*a, **k):
    copies[0] += 1
    return original(*a, **k)
devicearray.FakeCUDAArray.copy_to_host = counted
"""

DEFERRED = FAST_SIMULATOR + COUNT_COPIES + r"""
import json, numpy as np, wcsph
from wcsph.case.config import validate
from wcsph.errors import SimulationError


def case(every, c0=100.0):
    return validate({"name": "leaving", "dim": 2, "dp": 0.1, "precision": "float64",
                     "fluid": [{"min": [0.1, 0.0], "max": [0.6, 0.5], "velocity": ["30.0", "0.0"]}],
                     "domain": {"min": [-0.2, -0.2], "max": [0.6, 0.7]}, "model": {"name": "bi"},
                     "physics": {"gravity": [0.0, -9.81], "speed_of_sound": c0},
                     "time": {"end": 1.0, "max_steps": 8, "dt": 4e-4, "check_interval": every},
                     "output": {"progress": False}})

res = {}
for be, every in (("cpu", 1), ("cuda", 1), ("cuda", 4)):
    sim = wcsph.Simulation(case(every), backend=be)
    for _ in range(3):  # warm-up: the first steps upload and allocate
        sim.step(sim.time_step())
    copies[0] = 0
    for _ in range(4):
        sim.step(sim.time_step())
    stepping = copies[0]
    summary = sim.run()
    x, v, ids = sim.host(sim.fluid, "x", "v", "id")
    o = np.argsort(ids)
    res[f"{be}{every}"] = (x[:, o], v[:, o], sim.fluid.n, sim.dropped, sim.t, stepping, summary["checks_read_every"])
msgs = {}
for be, every in (("cpu", 1), ("cuda", 4)):
    try:  # 30 m/s against a sound speed of 20 m/s: the first step's check stops the run
        wcsph.Simulation(case(every, c0=20.0), backend=be).run()
    except SimulationError as e:
        msgs[be] = str(e)
c, g1, g4 = res["cpu1"], res["cuda1"], res["cuda4"]
print(json.dumps({"n": [c[2], g1[2], g4[2]], "dropped": [c[3], g1[3], g4[3]], "t": [c[4], g1[4], g4[4]],
                  "copies": [g1[5], g4[5]], "every": [g1[6], g4[6]],
                  "same": bool(np.array_equal(g1[0], g4[0]) and np.array_equal(g1[1], g4[1])),
                  "dx": float(np.abs(c[0] - g4[0]).max()) if c[2] == g4[2] else None, "messages": msgs}))
"""


SIZED = FAST_SIMULATOR + COUNT_COPIES + r"""
import json, sys, tempfile, numpy as np, wcsph
from pathlib import Path
from wcsph.case.config import validate


def case(every):  # the classic model's XSPH: P fields made from each step's size
    return validate({"name": "column", "dim": 2, "dp": 0.05, "precision": "float64",
                     "fluid": [{"min": [0.0, 0.0], "max": [0.4, 0.4]}],
                     "tank": {"min": [0.0, 0.0], "max": [1.0, 0.8], "open_top": True},
                     "model": {"name": "classic", "xsph_epsilon": 0.5},
                     "time": {"end": 0.02, "check_interval": every},
                     "output": {"progress": False, "vtk": False, "interval": 0.01, "probe_interval": 0.0025}})

res = {}
for be, every in (("cpu", 1), ("cuda", 1), ("cuda", 4)):
    sim = wcsph.Simulation(case(every), backend=be)
    sized = sim.time_step_rule.check is not None
    sim.step(sim.time_step())  # warm-up: the first step uploads and allocates
    copies[0] = 0
    for _ in range(8):
        sim.step(sim.time_step())
    stepping = copies[0]
    with tempfile.TemporaryDirectory() as out:
        summary = sim.run(output=out)
        rows = (Path(out) / "probes.csv").read_text()
    x, ids = sim.host(sim.fluid, "x", "id")
    res[f"{be}{every}"] = dict(x=x[:, np.argsort(ids)], t=sim.t, steps=sim.steps, copies=stepping, sized=sized,
                               rows=rows, every=summary["checks_read_every"])
c, g1, g4 = res["cpu1"], res["cuda1"], res["cuda4"]
print(json.dumps({"t": [c["t"], g1["t"], g4["t"]], "steps": [c["steps"], g1["steps"], g4["steps"]],
                  "copies": [g1["copies"], g4["copies"]], "sized": [g1["sized"], g4["sized"]],
                  "every": [g1["every"], g4["every"]], "rows": g4["rows"].count("\n"),
                  "same_rows": g1["rows"] == g4["rows"], "same": bool(np.array_equal(g1["x"], g4["x"])),
                  "dx": float(np.abs(c["x"] - g4["x"]).max())}))
"""


def test_an_adaptive_step_is_sized_on_the_device():
    """With an adaptive step the device makes each step's size from the last check (and XSPH's
    epsilon/dt with it), so the host reads every ``check_interval`` steps there too: over
    eight steps two copies to the host instead of eight (one per step and a count). The run
    with probes every 0.0025 s reads before each could fall due: its probes.csv (time, step,
    dt, energies) is that of the run that reads each step, character for character, and so
    are the positions and the end time; the CPU's to round-off."""
    r = subprocess.run([sys.executable, "-c", SIZED], capture_output=True, text=True, env=_env(), timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    assert res["sized"] == [False, True] and res["every"] == [1, 4], res
    assert res["copies"][0] >= 8 and res["copies"][1] == 2, res
    assert res["rows"] >= 5 and res["same_rows"] and res["same"], res  # a header, a row each 0.0025 s
    assert res["steps"][0] == res["steps"][1] == res["steps"][2] and res["t"][1] == res["t"][2], res
    assert abs(res["t"][0] - res["t"][2]) < 1e-15 and res["dx"] < 1e-12, res


def test_a_constant_step_reads_the_device_every_few_steps():
    """At a constant time step the host reads the device's checks every ``check_interval``
    steps (``solver.check``): over four steps, one copy to the host instead of four. A block
    thrown out of the domain at 30 m/s (particles leave at the fourth of eight steps, between
    two reads): the device parks them beyond the grid until the read and drops them then, and
    every number is the one of the run that reads each step, bit for bit, and the CPU's to
    round-off; the same particles are dropped. A run that blows up names the same first bad
    step as the CPU's, read three steps later."""
    env = _env()
    r = subprocess.run([sys.executable, "-c", DEFERRED], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    assert res["every"] == [1, 4], res
    assert res["copies"][0] >= 4 and res["copies"][1] == 1, res  # each check (and a count), one ring
    assert res["dropped"][0] == res["dropped"][1] == res["dropped"][2] > 0, res
    assert res["n"][0] == res["n"][1] == res["n"][2] and res["t"][0] == res["t"][2], res
    assert res["same"] and res["dx"] < 1e-12, res
    m = res["messages"]
    assert "runaway velocity" in m["cpu"] and "(step 1)" in m["cpu"], m
    assert m["cuda"].split(";")[0] == m["cpu"].split(";")[0], m
