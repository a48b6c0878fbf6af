"""Dam-break surge front of the 2D case against Martin & Moyce (1952) and Koshizuka & Oka
(1996): runs ``dam_break_2d`` to T = t sqrt(2g/a) = 3, prints the error at each reference
point, with the clocks started together and with each experiment's fitted release delay
(``wcsph.validation.references.surge_front_error``), and writes ``surge_front.png``.

    python validation/dam_break_surge_front.py [--dp 0.01] [--out runs/validation]
"""
import argparse
import csv
from pathlib import Path

import numpy as np

import wcsph
from wcsph.validation.references import surge_front, surge_front_error


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dp", type=float, default=0.01)
    ap.add_argument("--out", default="runs/validation")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    a, g = 1.0, 9.81
    scale = np.sqrt(2 * g / a)
    out = Path(args.out)
    overrides = [("dp", args.dp), ("time.end", 3.0 / scale), ("output.vtk", False),
                 ("output.interval", 0.005)] + [wcsph.case.config.parse_override(s) for s in args.sets]
    summary = wcsph.run("dam_break_2d", output=out, overrides=overrides, progress=False)
    with open(out / "probes.csv") as f:
        rows = list(csv.DictReader(f))
    T = np.array([float(r["time"]) for r in rows]) * scale
    Z = np.array([float(r["surge_front"]) for r in rows]) / a

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(T, Z, "k-", label=f"wcsph classic, dp = a/{a / args.dp:.0f} ({summary['n_fluid']} particles)")
    for name, marker, label in [("martin_moyce_1952", "o", "Martin & Moyce (1952)"),
                                ("koshizuka_oka_1996", "s", "Koshizuka & Oka (1996)")]:
        rT, rZ = surge_front(name)
        shown = rT <= T[-1] + 0.5
        ax.plot(rT[shown], rZ[shown], marker, mfc="none", label=label)
        for delay in (0.0, None):
            d, pts, err = surge_front_error(T, Z, name, t_max=T[-1], **({"max_delay": 0.0} if delay == 0.0 else {}))
            print(f"{label}, release delay dT = {d:.3f}: " + ", ".join(f"T={t:.2f} {e:+.1%}" for t, e in zip(pts, err)))
    d, _, _ = surge_front_error(T, Z, "martin_moyce_1952", t_max=T[-1])
    ax.plot(T + d, Z, "k--", label=f"the same, released dT = {d:.2f} later (fitted to Martin & Moyce)")
    ax.set_xlim(0, 1.1 * T[-1])
    ax.set_ylim(0.8, 1.2 * Z.max())
    ax.set_xlabel(r"$T = t\sqrt{2g/a}$")
    ax.set_ylabel(r"$Z = z/a$")
    ax.set_title("2D dam break: surge front")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "surge_front.png", dpi=120)
    print(f"wrote {out / 'surge_front.png'}")


if __name__ == "__main__":
    main()
