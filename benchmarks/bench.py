"""Speed of the full time step (sort, derivative evaluations, integration, wall corrections,
checks) in fluid particle-steps per second, for the 2D dam breaks at about 25 k, 100 k and
400 k fluid particles and the 3D ones at about 100 k, for each model.

    python benchmarks/bench.py [--models classic bi] [--precision float32] [--backend cpu]
                               [--sizes 25000 100000 400000] [--size-3d 100000]

Compilation (or loading Numba's cache) happens in warm-up steps before timing. The last
column is the rate relative to the first row, measured in the same run (hosts of one kind
differ by 2x in absolute figures; ratios measured side by side hold).
"""
import argparse

from _measure import host, rate, setup

CASES = {"classic": ("dam_break_2d", "dam_break_3d"), "bi": ("dam_break_2d_bi", "dam_break_3d_bi")}


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
    print(f"{args.precision} on {args.backend}; {host()}")
    print("| case | fluid particles | wall particles | ms/step | M particle-steps/s | rate / first row |")
    print("|---|---:|---:|---:|---:|---:|")
    first = None
    for name, n in runs:
        sim = setup(name, n, precision=args.precision, backend=args.backend)
        t, r = rate(sim, args.seconds)
        first = first or r
        print(f"| {name} | {sim.fluid.n:,} | {sim.walls.n:,} | {t * 1e3:.2f} | {r / 1e6:.2f} | {r / first:.2f} |",
              flush=True)


if __name__ == "__main__":
    main()
