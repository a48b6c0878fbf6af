"""SPHERIC test 6: the moving square's drag, its pressure part and its viscous part, against
the reference's C_D,p and C_D,v (mean over 2 <= t <= 6 s).

The body's load is p_b n_b S_b plus the reaction of the viscous wall term (``physics.loads``).
The run is made twice, the second time with the load pass built without the shear (the
flow is the same bit for bit: the load pass writes only the loads), so the viscous part is
the difference of the two.

    python validation/moving_square_parts.py [--dp 0.05] [--set KEY=JSON ...]
"""
import argparse
import csv
import json
import tempfile
from pathlib import Path

import numpy as np

import wcsph.models.wcsph as model
from wcsph.validation import _sim
from wcsph.validation import references as ref


def drag(dp, overrides, pressure_only):
    make = model.make_element_loads
    if pressure_only:
        model.make_element_loads = lambda ctx, shear, consistent: make(ctx, None, consistent)
    try:
        sim = _sim("moving_square_2d", [("time.end", 6.0), ("output.vtk", False), ("output.progress", False),
                                        ("output.probe_interval", 0.01), ("dp", dp)] + overrides)
    finally:
        model.make_element_loads = make
    with tempfile.TemporaryDirectory() as tmp:
        sim.run(tmp, progress=False)
        with open(Path(tmp) / "probes.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    t = np.array([float(r["time"]) for r in rows])
    return t, -2.0 * np.array([float(r["square_fx"]) for r in rows]), sim.n_fluid()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dp", type=float, default=0.05)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=JSON")
    a = ap.parse_args()
    over = [(k, json.loads(v)) for k, v in (s.split("=", 1) for s in a.set)]
    t, total, n = drag(a.dp, over, False)
    _, pressure, _ = drag(a.dp, over, True)
    d = np.loadtxt(ref.DATA / "spheric6_moving_square_drag_re100.dat", skiprows=2)
    rs = (d[:, 0] >= 2.0) & (d[:, 0] <= 6.0)
    s = (t >= 2.0) & (t <= 6.0)
    print(f"dp = {a.dp} ({1 / a.dp:g} across), {n} fluid particles; mean over 2-6 s:")
    print("| part | SPH | reference | error |\n|---|---|---|---|")
    for name, sph, r in (("C_D", total[s].mean(), (d[rs, 1] + d[rs, 2]).mean()),
                         ("C_D,p", pressure[s].mean(), d[rs, 1].mean()),
                         ("C_D,v", (total - pressure)[s].mean(), d[rs, 2].mean())):
        print(f"| {name} | {sph:.3f} | {r:.3f} | {sph / r - 1:+.1%} |")


if __name__ == "__main__":
    main()
