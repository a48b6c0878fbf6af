"""Small cases and a shared machine: the step rate of the 2D dam breaks at about 2.5 k, 10 k
and 100 k fluid particles, idle and with one CPU-bound process beside the run, as ratios
measured in this one run (against the 100 k rate, and loaded against idle).

    python benchmarks/sizes.py [--models classic bi] [--sizes 2500 10000 100000] [--seconds 4] [--rounds 4]

Goals (issue 9): 2.5 k at >= 0.8 of the 100 k rate, idle and loaded; loaded/idle <= 1.5.
"""
import argparse

import numpy as np

from _measure import busy_neighbour, host, rate, setup

CASES = {"classic": "dam_break_2d", "bi": "dam_break_2d_bi"}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=["classic", "bi"], choices=sorted(CASES))
    ap.add_argument("--sizes", type=int, nargs="+", default=[2_500, 10_000, 100_000])
    ap.add_argument("--seconds", type=float, default=4.0, help="stepping per size and state, all rounds")
    ap.add_argument("--rounds", type=int, default=4)
    args = ap.parse_args()
    print(host())
    print("| case | fluid particles | idle ms/step | idle M/s | idle / largest | loaded ms/step | "
          "loaded / largest | loaded time / idle time |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for model in args.models:
        # all sizes set up side by side, then timed in turns (idle, then loaded) over several
        # rounds, the median kept: a shared host's own load drifts by 20 % within a minute
        sims = [setup(CASES[model], n) for n in args.sizes]
        idle = [[] for _ in sims]
        loaded = [[] for _ in sims]
        per = args.seconds / args.rounds
        for _ in range(args.rounds):
            for k, sim in enumerate(sims):
                idle[k].append(rate(sim, per, windows=1)[0])
            with busy_neighbour():
                for k, sim in enumerate(sims):
                    loaded[k].append(rate(sim, per, windows=1)[0])
        rows = [(sim.fluid.n, float(np.median(i)), float(np.median(lo))) for sim, i, lo in zip(sims, idle, loaded)]
        n_big, it_big, lt_big = rows[-1]
        for n, it, lt in rows:
            print(f"| {CASES[model]} | {n:,} | {it * 1e3:.2f} | {n / it / 1e6:.2f} | "
                  f"{(n / it) / (n_big / it_big):.2f} | {lt * 1e3:.2f} | {(n / lt) / (n_big / lt_big):.2f} | "
                  f"{lt / it:.2f} |", flush=True)

if __name__ == "__main__":
    main()
