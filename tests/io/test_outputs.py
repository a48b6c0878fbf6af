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
from wcsph.io.vtk import read_image


def _series(path):
    return [(float(d.get("timestep")), d.get("file")) for d in ET.parse(path).getroot().iter("DataSet")]


def test_still_tank_surface_lies_at_the_water_level(tmp_path, capsys):
    """hydrostatic_2d (H = 0.5 m, dp = 0.02 m) after 0.2 s: the surface's points away from the
    walls lie within dp/2 of the water level (the column shortens by its compression,
    rho0 g H / (2 c0^2) of H, 2.5 mm here, inside that); ``wcsph surface`` on the finished
    run writes the same surfaces as the run did: both read each particle's own mass (the
    frames carry ``m``), which with a continuity density is rho(0) V_cell, up to 0.5 % off
    run.json's particle_mass here (the command read that one until 2026-12-08); the column
    starts at its hydrostatic density under the whole of gravity (with the case's ramp the
    compressed column would rise)."""
    out = tmp_path / "tank"
    assert main(["run", "hydrostatic_2d", "-o", str(out), "--end-time", "0.2", "--no-progress",
                 "--set", "output.surface=true", "--set", "output.interval=0.1",
                 "--set", 'model.density="continuity"', "--set", "physics.gravity_ramp_time=0"]) == 0
    first = meshio.read(out / "fluid_0000.vtu")
    mass = json.loads((out / "run.json").read_text())["particle_mass"]
    assert np.ptp(first.point_data["m"]) > 1e-3 * mass  # the masses differ from particle to particle
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
        assert after.shape == before.shape and np.abs(after - before).max() < 1e-9


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
    deps = tomllib.loads(Path(__file__).parents[2].joinpath("pyproject.toml").read_text())["project"]["dependencies"]
    names = {d.split("==")[0] for d in deps}
    assert {"matplotlib", "scikit-image"} <= names
    out = tmp_path / "run"
    assert main(["run", "hydrostatic_2d", "-o", str(out), "--end-time", "0.02", "--no-progress",
                 "--set", "output.vtk=false"]) == 0
    assert main(["plot", str(out)]) == 0
    assert any(p.suffix == ".png" and p.stat().st_size > 1000 for p in out.iterdir())
    assert json.loads((out / "run.json").read_text())["kernel"] == "wendland"


def test_grid_through_still_water_reads_the_hydrostatic_pressure(tmp_path):
    """hydrostatic_2d half a second after its gravity ramp (1 s): on a vertical line of nodes
    through the tank, p is within 1 % of rho0 g (H - z) from the floor's kernel support up to
    one below the surface (measured 0.86 %: the particles' own pressure noise, largest where
    p is smallest), H the level where the line's kernel sum falls to 1/2 (the column stands
    1.8 mm below its initial 0.5 m, compressed); nodes in the air read 0. A plane grid at its
    own rate gives its frames at its own times."""
    grids = [{"name": "line", "origin": [0.5, 0.0], "axes": [[0.0, 0.6]], "counts": [61]},
             {"name": "plane", "origin": [0.0, 0.0], "axes": [[1.0, 0.0], [0.0, 0.7]], "counts": [21, 15],
              "interval": 0.5}]
    out = tmp_path / "tank"
    import wcsph

    wcsph.run("hydrostatic_2d", output=out, progress=False,
              overrides=[("time.end", 1.5), ("output.vtk", False), ("output.interval", 0.75), ("grids", grids)])
    assert [t for t, _ in _series(out / "grid_line.pvd")] == pytest.approx([0.0, 0.75, 1.5], abs=1e-3)
    assert len(_series(out / "grid_plane.pvd")) == 4
    last = out / _series(out / "grid_line.pvd")[-1][1]
    img = ET.parse(last).getroot()  # as VTK reads it: an image, a UInt32 byte count before each array
    assert img.get("type") == "ImageData" and img.get("header_type") == "UInt32"
    assert img.find("ImageData").get("WholeExtent") == "0 0 0 60 0 0"
    origin, spacing, counts, f = read_image(last)
    assert counts == [1, 61, 1] and spacing[1] == pytest.approx(0.01) and origin[:2] == [0.5, 0.0]
    z = 0.01 * np.arange(61)
    w, p = f["kernel_sum"][:, 0], f["p"][:, 0]
    k = np.flatnonzero((w[:-1] >= 0.5) & (w[1:] < 0.5))[-1]
    H = z[k] + 0.01 * (w[k] - 0.5) / (w[k] - w[k + 1])
    assert abs(H - 0.5) < 0.005
    support = 0.08  # 2 h, h = 2 dp
    sel = (z >= support) & (z <= H - support)
    ref = 1000.0 * 9.81 * (H - z[sel])
    assert sel.sum() > 20 and np.abs(p[sel] / ref - 1).max() < 0.01
    assert (p[z > H + support] == 0).all() and (w[z > H + support] < 0.1).all()
    _, _, counts, f = read_image(out / "grid_plane_0003.vti")
    assert counts == [21, 15, 1] and f["v"].shape == (21 * 15, 3)


def test_flow_through_a_section_is_the_inlets(tmp_path):
    """poiseuille_open_2d (40 particles across): the mass flux through sections at x = 0.5,
    1.0 and 1.5, averaged over 1-2 s, is the inlet's, rho0 times int_0^1 4 y (1 - y) dy = 2/3
    (buffer particles of rho0's mass leave the inlet at the prescribed velocity), within 1 %
    (measured -0.1 %), and the same at the three sections within 0.5 %; the volume flux is the
    mass flux over the channel's density (1 % above rho0 there, its pressure over c0^2)."""
    import csv

    import wcsph

    sections = [{"name": f"q{k}", "kind": "flow", "position": [x, 0.5], "normal": [1.0, 0.0]}
                for k, x in enumerate((0.5, 1.0, 1.5))]
    wcsph.run("poiseuille_open_2d", output=tmp_path, progress=False,
              overrides=[("time.end", 2.0), ("output.vtk", False), ("output.probe_interval", 0.05),
                         ("probes", sections)])
    rows = [r for r in csv.DictReader(open(tmp_path / "probes.csv")) if float(r["time"]) >= 1.0]
    mass = np.array([[float(r[f"q{k}_mass_flux"]) for r in rows] for k in range(3)]).mean(axis=1)
    vol = np.array([[float(r[f"q{k}_volume_flux"]) for r in rows] for k in range(3)]).mean(axis=1)
    assert np.abs(mass / (2 / 3) - 1).max() < 0.01
    assert mass.max() / mass.min() - 1 < 0.005
    assert np.all((vol < mass) & (vol > 0.98 * mass))


@pytest.mark.parametrize("change, key", [
    ({"grids": [{"name": "g", "origin": [0.1, 0.1], "axes": [[0.5, 0.5]], "counts": [5]}]}, "grids[0].axes[0]"),
    ({"grids": [{"name": "g", "origin": [0.1, 0.1], "axes": [[0.5, 0.0]], "counts": [5, 3]}]}, "grids[0].counts"),
    ({"grids": [{"name": "g", "origin": [0.1, 0.1], "axes": [[0.5, 0.0]], "counts": [1]}]}, "grids[0].counts"),
    ({"grids": [{"name": "a/b", "origin": [0.1, 0.1], "axes": [[0.5, 0.0]], "counts": [3]}]}, "grids[0].name"),
    ({"probes": [{"name": "q", "kind": "flow", "position": [0.5, 0.5]}]}, "probes[0].normal"),
])
def test_grid_and_section_errors_name_the_key(change, key):
    from wcsph.case.config import validate
    from wcsph.errors import CaseError

    base = {"dim": 2, "dp": 0.1, "time": {"end": 0.1}, "fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.5]}],
            "tank": {"min": [0.0, 0.0], "max": [1.0, 1.0]}}
    with pytest.raises(CaseError, match=key.replace("[", r"\[").replace("]", r"\]")):
        validate(dict(base, **change))


def test_grid_outside_the_domain_is_one_line(tmp_path, capsys):
    case = tmp_path / "c.toml"
    case.write_text('dim = 2\ndp = 0.1\n[time]\nend = 0.1\n[[fluid]]\nmin = [0.0, 0.0]\nmax = [1.0, 0.5]\n'
                    '[tank]\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]\n[[grids]]\nname = "g"\norigin = [0.1, 0.1]\n'
                    'axes = [[5.0, 0.0]]\ncounts = [11]\n')
    assert main(["run", str(case), "-o", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "grids[0]" in err and "outside the domain" in err and "Traceback" not in err


def test_surface_of_the_3d_dam_break_is_closed_at_every_frame(tmp_path):
    """The shipped dam_break_3d (coarse, 0.3 s, through the impact on the far wall): every
    frame's surface is in surface.pvd and closed (each edge shared by two triangles)."""
    import wcsph

    wcsph.run("dam_break_3d", output=tmp_path, progress=False,
              overrides=[("dp", 0.04), ("time.end", 0.3), ("output.vtk", False), ("output.interval", 0.05),
                         ("output.surface", True)])
    frames = _series(tmp_path / "surface.pvd")
    assert len(frames) == 7
    for _, name in frames:
        tri = meshio.read(tmp_path / name).cells[0].data
        edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
        _, uses = np.unique(edges, axis=0, return_counts=True)
        assert len(tri) > 500 and (uses == 2).all(), name
