"""Speed of the full time step (sort, derivative evaluations, integration, wall corrections,
checks) in fluid particle-steps per second, for the 2D dam breaks at about 25 k, 100 k and
400 k fluid particles and the 3D ones at about 100 k, for each model.

    python benchmarks/bench.py [--models classic bi] [--precision float32] [--backend cpu]
                               [--sizes 25000 100000 400000] [--size-3d 100000]

Compilation (or loading Numba's cache) happens in warm-up steps before timing.
"""
import argparse
import time

import numpy as np

import wcsph
from wcsph.config import load

COLUMN = {"dam_break_2d": 1.0 * 2.0, "dam_break_3d": 0.3 * 0.4 * 0.6,
          "dam_break_2d_bi": 0.6 * 0.3, "dam_break_3d_bi": 0.3 * 0.4 * 0.6}
CASES = {"classic": ("dam_break_2d", "dam_break_3d"), "bi": ("dam_break_2d_bi", "dam_break_3d_bi")}


def measure(name, n_target, precision, backend, budget_s):
    dim = 2 if "_2d" in name else 3
    dp = (COLUMN[name] / n_target) ** (1.0 / dim)
    case = load(name, [("dp", dp), ("precision", precision), ("backend", backend)])
    t0 = time.perf_counter()
    sim = wcsph.Simulation(case)
    for _ in range(3):
        sim.step(sim.time_step())
    setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    steps = 0
    while steps < 10 or time.perf_counter() - t0 < budget_s:
        sim.step(sim.time_step())
        steps += 1
    elapsed = time.perf_counter() - t0
    return {"case": name, "dim": dim, "dp": dp, "n_fluid": sim.fluid.n, "n_walls": sim.walls.n,
            "ms_per_step": 1e3 * elapsed / steps, "mps": sim.fluid.n * steps / elapsed / 1e6,
            "setup_s": setup, "steps": steps}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=["classic", "bi"], choices=sorted(CASES))
    ap.add_argument("--precision", default="float32", choices=["float32", "float64"])
    ap.add_argument("--backend", default="cpu", choices=["cpu", "cuda"])
    ap.add_argument("--sizes", type=int, nargs="+", default=[25_000, 100_000, 400_000])
    ap.add_argument("--size-3d", type=int, default=100_000)
    ap.add_argument("--seconds", type=float, default=3.0, help="timed stepping per size")
    args = ap.parse_args()
    runs = []
    for model in args.models:
        two, three = CASES[model]
        runs += [(two, n) for n in args.sizes] + ([(three, args.size_3d)] if args.size_3d else [])
    print(f"{args.precision} on {args.backend}")
    print("| case | fluid particles | wall particles | ms/step | M particle-steps/s | ms/step per 100k |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, n in runs:
        r = measure(name, n, args.precision, args.backend, args.seconds)
        print(f"| {r['case']} | {r['n_fluid']:,} | {r['n_walls']:,} | {r['ms_per_step']:.2f} | "
              f"{r['mps']:.2f} | {r['ms_per_step'] / r['n_fluid'] * 1e5:.2f} |", flush=True)


if __name__ == "__main__":
    main()
