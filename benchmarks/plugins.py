"""The cost of each plug-in choice: the step rate of the 2D dam break of each model at about
25 k fluid particles with one slot changed at a time, as the ratio of each choice's step
time to the cheapest choice of the same slot (issue 9's goal: no choice above ~1.3).

    python benchmarks/plugins.py [--size 25000] [--seconds 3] [--rounds 6]
"""
import argparse

import numpy as np

from _measure import host, rate, setup

#: slot -> [(label, overrides)]; the first entry of each model is its shipped setting
SLOTS = {
    "dam_break_2d_bi": {
        "ViscousTerm": [(v, [("model.ViscousTerm", v)]) for v in
                        ("None", "ArtificialViscosity", "PhysicalViscosity_MVT", "PhysicalViscosity_MGVT")],
        "DiffusiveTerm": [(v, [("model.DiffusiveTerm", v)]) for v in
                          ("None", "MolteniDiffusiveTerm", "FourtakasDiffusiveTerm")],
        "BCType": [(v, [("model.BCType", v)]) for v in ("BIConservative_numeric", "BIConsistent_numeric")],
        "EOS": [(v, [("model.EOS", v)]) for v in ("ColeEquationOfState", "LinearizedColeEquationOfState")],
        "wall corrections": [("none", [("model.enableElasticBounce", False), ("model.enableNearBoundaryShifting", False)]),
                             ("elastic bounce", [("model.enableElasticBounce", True), ("model.enableNearBoundaryShifting", False)]),
                             ("bounce + NBVC-PST", [("model.enableElasticBounce", True),
                                                    ("model.enableNearBoundaryShifting", True)])],
    },
    "dam_break_2d": {
        "xsph": [(v, [("model.xsph", v)]) for v in ("None", "momentum", "position")],
        "pressure": [(v, [("model.pressure", v)]) for v in ("Monaghan1992", "BISymmetric",
                                                            "Monaghan1992ArtificialViscosity")],
        "density": [("summation", []), ("continuity + Molteni", [("model.density", "continuity"),
                                                                 ("model.DiffusiveTerm", "MolteniDiffusiveTerm")])],
        "kernel_correction": [(v, [("model.kernel_correction", v)]) for v in ("None", "CSPM")],
        "shifting": [(v, [("model.shifting", v)]) for v in ("None", "Lind", "DeltaPlus")],
        "collision": [(v, [("model.collision", v)]) for v in ("None", "DPC")],
        "wall_xsph": [("off", [("model.wall_xsph", 0.0)]), ("0.05", [("model.wall_xsph", 0.05)])],
    },
}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=25_000)
    ap.add_argument("--seconds", type=float, default=3.0, help="stepping per choice, all rounds")
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--slots", nargs="+", help="only these slots (e.g. shifting collision)")
    args = ap.parse_args()
    print(host())
    print("| case | slot | choice | ms/step | M particle-steps/s | time / cheapest of the slot |")
    print("|---|---|---|---:|---:|---:|")
    for case, slots in SLOTS.items():
        for slot, choices in slots.items():
            if args.slots and slot not in args.slots:
                continue
            # every choice of the slot set up side by side and timed in turns, the median of
            # the rounds kept: a shared host's load drifts by 20 % within a minute
            sims = [(label, setup(case, args.size, overrides)) for label, overrides in choices]
            times = {label: [] for label, _ in sims}
            for _ in range(args.rounds):
                for label, sim in sims:
                    times[label].append(rate(sim, args.seconds / args.rounds, windows=1)[0])
            rows = [(label, float(np.median(times[label])), sim.fluid.n) for label, sim in sims]
            cheapest = min(t for _, t, _ in rows)
            for label, t, n in rows:
                print(f"| {case} | {slot} | {label} | {t * 1e3:.2f} | {n / t / 1e6:.2f} | {t / cheapest:.2f} |",
                      flush=True)


if __name__ == "__main__":
    main()
