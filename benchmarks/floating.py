"""What a floating body costs a step: each stage of the step timed over a window, for
`floating_box_2d` at about 100 k fluid particles (issue's goal: the body's stages under 10 %
of the step), in WCSPH-BI (the case's model) and in the classic model (the model the classic
Fekken check runs: wall particles, no-slip by Adami's velocity, XSPH).

    python benchmarks/floating.py [--n 100000] [--steps 40] [--models bi classic]
    python benchmarks/floating.py --case floating_box_waves_3d [--dp 0.04]

``--case``: another shipped case with a floating body, at its own dp (or ``--dp``), its first
floating body released at once; ``--n`` sizes `floating_box_2d` only. ``--backend cuda``: on a
GPU, the device synchronised after each stage, so that each is timed whole (the step then
waits where a run does not: the stages' shares, not the run's speed).
The body is released at once (``floating.release = 0``), so that it moves from the first
step; per stage: the median over ``--windows`` windows of the mean over its steps.
"""
import argparse
import statistics
import time

import wcsph
from wcsph.case.config import read_toml, resolve, validate

from _measure import host

#: the fluid's area in `floating_box_2d` (2 x 0.5 m, less the box's immersed part)
AREA = 2.0 * 0.5


def case_for(model, n, name="floating_box_2d", dp=None, backend="cpu"):
    data = read_toml(resolve(name))
    data["backend"] = backend
    data["dp"] = dp or ((AREA / n) ** 0.5 if name == "floating_box_2d" else data["dp"])
    sources = [t for key in ("obstacle", "polygon", "walls") for t in data.get(key, [])]
    body = next((t for t in sources if "floating" in t), None)
    if body is None:
        raise SystemExit(f"{name}: no floating body")
    body["floating"]["release"] = 0.0
    data["output"]["progress"] = False
    if model == "classic":
        data["model"] = {"name": "classic", "kernel": "wendland", "smoothing_ratio": 2.0, "xsph_epsilon": 0.01,
                         "ViscousTerm": "ArtificialViscosity", "alpha": data["model"].get("alpha", 0.02),
                         "wall_velocity": "adami"}
    return validate(data)


def measure(model, n, steps, windows, name="floating_box_2d", dp=None, backend="cpu"):
    sim = wcsph.Simulation(case_for(model, n, name, dp, backend))
    if backend == "cuda":
        from numba import cuda

        sync = cuda.synchronize
    else:
        def sync():
            pass
    for _ in range(5):  # compile or load, then the first steps' start-up
        sim.step(sim.time_step())
    names = [type(s).__name__ if not hasattr(s, "__self__") else s.__self__.__class__.__name__ + "." + s.__name__
             for s in sim.stages]
    per_window = []
    for _ in range(windows):
        spent = [0.0] * len(sim.stages)
        for _ in range(steps):
            sim.state.dt = sim.time_step()
            for k, stage in enumerate(sim.stages):
                t0 = time.perf_counter()
                stage(sim.state)
                sync()
                spent[k] += time.perf_counter() - t0
        per_window.append([s / steps for s in spent])
    stage_ms = [statistics.median(w[k] for w in per_window) * 1e3 for k in range(len(names))]
    return sim.fluid.n, names, stage_ms


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--windows", type=int, default=3)
    ap.add_argument("--models", nargs="+", default=["bi", "classic"])
    ap.add_argument("--case", default="floating_box_2d")
    ap.add_argument("--dp", type=float, default=None)
    ap.add_argument("--backend", choices=("cpu", "cuda"), default="cpu")
    a = ap.parse_args()
    print(host())
    for model in a.models:
        n, names, ms = measure(model, a.n, a.steps, a.windows, a.case, a.dp, a.backend)
        total = sum(ms)
        body = sum(m for name, m in zip(names, ms) if name in ("MoveBodies", "MoveWalls"))
        print(f"{a.case}, {model}, {a.backend}: {n} fluid particles, step {total:.2f} ms; the body's stages (MoveBodies, MoveWalls) "
              f"{body:.3f} ms = {100 * body / total:.1f} % of the step")
        print("  " + ", ".join(f"{name} {m:.3f}" for name, m in zip(names, ms)))


if __name__ == "__main__":
    main()
