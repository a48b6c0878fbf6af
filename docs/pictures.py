"""The README's post-processing pictures, made from one short run of the shipped
``dam_break_3d`` with every output on (about a minute on 2 cores):

    python docs/pictures.py [OUT_DIR]

writes docs/img/surface.png (the free surface at t = 0.3 s), docs/img/grid.png (p on the
mid-plane y = 0.2 m) and docs/img/flow.png (the flux through x = 0.6 m).
"""
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import meshio  # noqa: E402
import numpy as np  # noqa: E402

import wcsph  # noqa: E402

from wcsph.io.vtk import read_image  # noqa: E402

HERE = Path(__file__).parent


def main(out="runs/pictures"):
    out = Path(out)
    grids = [{"name": "mid", "origin": [0.0, 0.2, 0.0], "axes": [[1.2, 0.0, 0.0], [0.0, 0.0, 0.8]],
              "counts": [121, 81], "interval": 0.05}]
    probes = [{"name": "Q", "kind": "flow", "position": [0.6, 0.2, 0.3], "normal": [1.0, 0.0, 0.0]}]
    wcsph.run("dam_break_3d", output=out, progress=False,
              overrides=[("time.end", 0.4), ("output.vtk", True), ("output.interval", 0.1), ("output.surface", True),
                         ("output.probe_interval", 0.005), ("grids", grids), ("probes", probes)])
    img = HERE / "img"
    img.mkdir(exist_ok=True)

    m = meshio.read(out / "surface_0003.vtu")
    fig = plt.figure(figsize=(7, 4), dpi=110)
    ax = fig.add_subplot(projection="3d")
    p = m.points
    ax.plot_trisurf(p[:, 0], p[:, 1], p[:, 2], triangles=m.cells[0].data, cmap="Blues_r", linewidth=0,
                    antialiased=False)
    ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", xlim=(0, 1.2), ylim=(0, 0.4), zlim=(0, 0.6),
           title="surface_0003.vtu: the free surface at t = 0.3 s")
    ax.set_box_aspect((1.2, 0.4, 0.6))
    ax.set_yticks([0.0, 0.2, 0.4])
    ax.view_init(25, -60)
    fig.tight_layout()
    fig.savefig(img / "surface.png")
    plt.close(fig)

    origin, spacing, counts, f = read_image(out / "grid_mid_0006.vti")
    pa = f["p"][:, 0].reshape(counts[2], counts[0])  # x fastest
    fig, ax = plt.subplots(figsize=(7, 4), dpi=110)
    im = ax.imshow(np.ma.masked_where(f["kernel_sum"][:, 0].reshape(pa.shape) < 0.1, pa), origin="lower",
                   extent=(0, 1.2, 0, 0.8), cmap="viridis")
    fig.colorbar(im, label="p [Pa]")
    ax.set(xlabel="x [m]", ylabel="z [m]", title="grid_mid_0006.vti: p on the plane y = 0.2 m, t = 0.3 s")
    fig.tight_layout()
    fig.savefig(img / "grid.png")
    plt.close(fig)

    rows = list(csv.DictReader(open(out / "probes.csv")))
    t = [float(r["time"]) for r in rows]
    fig, ax = plt.subplots(figsize=(7, 3.5), dpi=110)
    ax.plot(t, [float(r["Q_volume_flux"]) for r in rows])
    ax.set(xlabel="t [s]", ylabel="Q [m$^3$/s]", title="probes.csv: the flux through x = 0.6 m")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(img / "flow.png")
    plt.close(fig)
    print("pictures in", img)


if __name__ == "__main__":
    main(*sys.argv[1:])
