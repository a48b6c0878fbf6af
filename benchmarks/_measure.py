"""What the benchmark scripts share: a case set up at a target particle count, and its step
rate measured over a time budget (after warm-up steps that compile or load the loops)."""
import subprocess
import sys
import time
from contextlib import contextmanager

import wcsph
from wcsph import load  # the package's own name for it, the same in every tree compare_trees.py runs

#: fluid volume (area in 2D) of each shipped dam break, to choose dp for a particle count
COLUMN = {"dam_break_2d": 1.0 * 2.0, "dam_break_3d": 0.3 * 0.4 * 0.6,
          "dam_break_2d_bi": 0.6 * 0.3, "dam_break_3d_bi": 0.3 * 0.4 * 0.6,
          "hydrostatic_2d": 1.0 * 0.5, "hydrostatic_2d_bi": 2.0 * 0.5, "spheric2_3d": 1.228 * 1.0 * 0.55}


def setup(name, n_target, overrides=(), precision="float32", backend="cpu"):
    dim = 3 if "_3d" in name else 2
    dp = (COLUMN[name] / n_target) ** (1.0 / dim)
    case = load(name, [("dp", dp), ("precision", precision), ("backend", backend), *overrides])
    sim = wcsph.Simulation(case)
    for _ in range(3):
        sim.step(sim.time_step())
    return sim


def rate(sim, seconds, windows=5, min_steps=4):
    """Step time (s) and fluid particle-steps per second over ``seconds`` of stepping: the
    median of ``windows`` equal windows, each the mean over its steps, so that a burst of
    another tenant's load on a shared host moves one window, not the figure."""
    per = []
    for _ in range(windows):
        t0 = time.perf_counter()
        steps = 0
        while steps < min_steps or time.perf_counter() - t0 < seconds / windows:
            sim.step(sim.time_step())
            steps += 1
        per.append((time.perf_counter() - t0) / steps)
    elapsed = sorted(per)[len(per) // 2]
    return elapsed, sim.fluid.n / elapsed


@contextmanager
def busy_neighbour():
    """One CPU-bound process beside the measurement (what a user's other program does)."""
    proc = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    time.sleep(0.3)
    try:
        yield
    finally:
        proc.kill()
        proc.wait()


def host():
    import os
    import platform

    import numba

    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            model = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return (f"{model}, {os.cpu_count()} cores, {numba.get_num_threads()} threads, "
            f"threading layer {numba.threading_layer()}")
