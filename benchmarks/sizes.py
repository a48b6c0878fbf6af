"""Small cases and a shared machine: the step rate of the 2D dam breaks at about 2.5 k, 10 k
and 100 k fluid particles, idle and with one CPU-bound process beside the run, as ratios
measured in this one run (against the 100 k rate, and loaded against idle).

    python benchmarks/sizes.py [--models classic bi] [--sizes 2500 10000 100000] [--seconds 3]

Goals (issue 9): 2.5 k at >= 0.8 of the 100 k rate, idle and loaded; loaded/idle <= 1.5.
"""
import argparse

from _measure import busy_neighbour, host, rate, setup

CASES = {"classic": "dam_break_2d", "bi": "dam_break_2d_bi"}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=["classic", "bi"], choices=sorted(CASES))
    ap.add_argument("--sizes", type=int, nargs="+", default=[2_500, 10_000, 100_000])
    ap.add_argument("--seconds", type=float, default=3.0)
    args = ap.parse_args()
    print(host())
    print("| case | fluid particles | idle ms/step | idle M/s | idle / largest | loaded ms/step | "
          "loaded / largest | loaded time / idle time |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for model in args.models:
        rows = []
        for n in args.sizes:
            sim = setup(CASES[model], n)
            idle_t, idle_r = rate(sim, args.seconds)
            with busy_neighbour():
                load_t, load_r = rate(sim, args.seconds)
            rows.append((sim.fluid.n, idle_t, idle_r, load_t, load_r))
        big_idle, big_load = rows[-1][2], rows[-1][4]
        for n, it, ir, lt, lr in rows:
            print(f"| {CASES[model]} | {n:,} | {it * 1e3:.2f} | {ir / 1e6:.2f} | {ir / big_idle:.2f} | "
                  f"{lt * 1e3:.2f} | {lr / big_load:.2f} | {lt / it:.2f} |", flush=True)


if __name__ == "__main__":
    main()
