"""Post-processing outputs: the free surface as a mesh (``output.surface``, ``wcsph surface``),
and plots from the base install."""
import json
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest

from wcsph.cli import main
from wcsph.io.surface import surface_mesh


def _series(path):
    return [(float(d.get("timestep")), d.get("file")) for d in ET.parse(path).getroot().iter("DataSet")]


def test_still_tank_surface_lies_at_the_water_level(tmp_path, capsys):
    """hydrostatic_2d (H = 0.5 m, dp = 0.02 m) after 0.2 s: the surface's points away from the
    walls lie within dp/2 of the water level (the column shortens by its compression,
    rho0 g H / (2 c0^2) of H, 2.5 mm here, inside that); ``wcsph surface`` on the finished
    run writes the same surfaces as the run did (to the float32 rounding of the particles'
    mass, which the run reads per particle and the command from run.json)."""
    out = tmp_path / "tank"
    assert main(["run", "hydrostatic_2d", "-o", str(out), "--end-time", "0.2", "--no-progress",
                 "--set", "output.surface=true", "--set", "output.interval=0.1"]) == 0
    frames = _series(out / "surface.pvd")
    assert [f for _, f in frames] == ["surface_0000.vtu", "surface_0001.vtu", "surface_0002.vtu"]
    assert [t for t, _ in frames] == [t for t, _ in _series(out / "fluid.pvd")]
    for _, name in frames:
        m = meshio.read(out / name)
        p = m.points
        mid = p[(p[:, 0] > 0.2) & (p[:, 0] < 0.8) & (p[:, 1] > 0.25)]
        assert len(mid) > 20 and np.abs(mid[:, 1] - 0.5).max() < 0.5 * 0.02, name
        assert m.cells[0].type == "line"
    written = [meshio.read(out / f).points for _, f in frames]
    assert main(["surface", str(out)]) == 0
    assert "3 surfaces written" in capsys.readouterr().out
    for (_, f), before in zip(frames, written):
        after = meshio.read(out / f).points
        assert after.shape == before.shape and np.abs(after - before).max() < 1e-6


def test_surface_of_a_3d_block_is_closed_and_at_its_faces():
    """A block of particles on a lattice: the surface is closed (every edge shared by two
    triangles) and its top within dp/2 of the block's top."""
    dp = 0.02
    axes = [np.arange(dp / 2, a, dp) for a in (0.2, 0.16, 0.3)]
    x = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")])
    pts, tri, kind = surface_mesh(x, np.full(x.shape[1], dp**3), 2 * dp, "wendland", dp / 2)
    assert kind == "triangle" and len(tri) > 1000
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    _, uses = np.unique(edges, axis=0, return_counts=True)
    assert (uses == 2).all()
    top = pts[(np.abs(pts[:, 0] - 0.1) < 0.03) & (np.abs(pts[:, 1] - 0.08) < 0.03), 2].max()
    assert abs(top - 0.3) < dp / 2


def test_surface_command_refuses_a_directory_that_is_not_a_run(tmp_path, capsys):
    assert main(["surface", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("wcsph: error:") and "run.json" in err and "Traceback" not in err


def test_plots_are_in_the_base_install(tmp_path):
    """matplotlib (plots) and scikit-image (surfaces) are base dependencies: the README's first
    command installs them, and ``wcsph plot`` works after it."""
    deps = tomllib.loads(Path(__file__).parents[1].joinpath("pyproject.toml").read_text())["project"]["dependencies"]
    names = {d.split("==")[0] for d in deps}
    assert {"matplotlib", "scikit-image"} <= names
    out = tmp_path / "run"
    assert main(["run", "hydrostatic_2d", "-o", str(out), "--end-time", "0.02", "--no-progress",
                 "--set", "output.vtk=false"]) == 0
    assert main(["plot", str(out)]) == 0
    assert any(p.suffix == ".png" and p.stat().st_size > 1000 for p in out.iterdir())
    assert json.loads((out / "run.json").read_text())["kernel"] == "wendland"
