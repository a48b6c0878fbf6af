"""SPHERIC test 6: the moving square's drag face by face (front, rear, top and bottom), its
wall pressure along the front and rear faces, mean over 2 <= t <= 6 s.

Each element's load (``physics.loads``: p_b n_b S_b plus the viscous wall term's reaction) is
read at every probe time; C_D of a face is -2 sum F_x / (rho U^2 L) over its elements. The
front and rear faces carry the pressure drag (and the viscous term's normal part, small), the
top and bottom the friction. One run.

    python validation/moving_square_faces.py [--dp 0.05] [--set KEY=JSON ...] [--out faces.npz]
"""
import argparse
import json
import tempfile

import numpy as np

from wcsph.solver import loads
from wcsph.validation import _sim
from wcsph.validation import references as ref


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dp", type=float, default=0.05)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=JSON")
    ap.add_argument("--out", default=None, help="save the faces' series and profiles (.npz)")
    a = ap.parse_args()
    over = [(k, json.loads(v)) for k, v in (s.split("=", 1) for s in a.set)]
    sim = _sim("moving_square_2d", [("time.end", 6.0), ("output.vtk", False), ("output.progress", False),
                                    ("output.probe_interval", 0.01), ("dp", a.dp)] + over)
    rho, U, L = 1.0, 1.0, 1.0
    p0 = sim.case["physics"]["p0"]
    rows = []  # (t, load of each square element, x of each, n of each)
    original = loads._wall_point_loads

    def recording(state, bodies, named):
        state.settle()
        w = state.walls
        load = state.backend.to_host(state.model.wall_loads(state.fluid, w, state.P, state.G)).astype(float)
        x, n, body, size = state.host(w, "x", "n", "body", "elementSize")
        sel = body == bodies.names.index("square")
        rows.append((state.t, load[:, sel], x[:, sel].astype(float), n[:, sel].astype(float), size[sel].astype(float)))
        return original(state, bodies, named)

    loads._wall_point_loads = recording
    try:
        with tempfile.TemporaryDirectory() as tmp:
            sim.run(tmp, progress=False)
    finally:
        loads._wall_point_loads = original
    t = np.array([r[0] for r in rows])
    s = (t >= 2.0) & (t <= 6.0)
    n = rows[0][3]
    faces = {"front": n[0] < -0.5, "rear": n[0] > 0.5, "top": n[1] < -0.5, "bottom": n[1] > 0.5}
    cd = {f: np.array([-2.0 * r[1][0, m].sum() / (rho * U * U * L) for r in rows]) for f, m in faces.items()}
    print(f"dp = {a.dp} ({1 / a.dp:g} across), {sim.n_fluid()} fluid particles, {len(n[0])} square elements;"
          " C_D per face, mean over 2-6 s:")
    print("| face | elements | C_D |\n|---|---|---|")
    for f, m in faces.items():
        print(f"| {f} | {m.sum()} | {cd[f][s].mean():+.3f} |")
    print(f"| front + rear | | {(cd['front'] + cd['rear'])[s].mean():+.3f} |")
    print(f"| top + bottom | | {(cd['top'] + cd['bottom'])[s].mean():+.3f} |")
    d = np.loadtxt(ref.DATA / "spheric6_moving_square_drag_re100.dat", skiprows=2)
    total = sum(cd.values())
    r = np.interp(t[s], d[:, 0], d[:, 1] + d[:, 2])
    rs = (d[:, 0] >= 2.0) & (d[:, 0] <= 6.0)
    print(f"total C_D {total[s].mean():.3f} against {(d[rs, 1] + d[rs, 2]).mean():.3f} "
          f"({total[s].mean() / (d[rs, 1] + d[rs, 2]).mean() - 1:+.1%}), RMS of the difference "
          f"{np.sqrt(np.mean((total[s] - r) ** 2)):.3f}; the box's mean pressure above p0 at the end: "
          f"{0.25 * rho * U * U * (cd['front'][-1] - cd['rear'][-1]) - p0:.2f} Pa (the mean of the front and rear "
          "faces' pressure)")
    # the wall pressure along the front and rear faces: (load . n) / S - p0, in units of rho U^2 / 2
    prof = {}
    for f in ("front", "rear"):
        m = faces[f]
        y = rows[0][2][1, m] - rows[0][2][1, m].mean()
        p = np.mean([(r[1][0, m] * r[3][0, m] + r[1][1, m] * r[3][1, m]) / r[4][m] for r, k in zip(rows, s) if k],
                    axis=0)
        o = np.argsort(y)
        prof[f] = (y[o], (p[o] - p0) / (0.5 * rho * U * U))
        print(f"{f}: C_p(y) from y = -L/2 to L/2:", " ".join(f"{v:+.2f}" for v in prof[f][1]))
    if a.out:
        np.savez(a.out, t=t, **{f"cd_{f}": v for f, v in cd.items()},
                 **{f"y_{f}": v[0] for f, v in prof.items()}, **{f"cp_{f}": v[1] for f, v in prof.items()})


if __name__ == "__main__":
    main()
