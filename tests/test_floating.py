"""Floating rigid bodies (``floating``): mass properties from the geometry, the rigid-body
step, and a box floating at Archimedes' draft."""
import csv

import numpy as np
import pytest

import wcsph
from wcsph.config import validate
from wcsph.errors import CaseError
from wcsph.floating import box_properties, mesh_properties, polygon_properties


def test_mass_properties_of_boxes_polygons_and_meshes():
    """A rectangle as a box, as a polygon (either orientation) and as a closed 2D outline;
    a box as a box and as a triangle mesh of its faces: the same area or volume, centroid and
    inertia (2D: b h (b^2 + h^2) / 12; 3D: the box's diagonal tensor)."""
    lo, hi = [0.2, 0.1], [0.6, 0.4]
    area, c, j = box_properties(lo, hi)
    assert area == pytest.approx(0.12) and np.allclose(c, [0.4, 0.25]) and j == pytest.approx(0.12 * (0.16 + 0.09) / 12)
    rect = [[0.2, 0.1], [0.6, 0.1], [0.6, 0.4], [0.2, 0.4]]
    for pts in (rect, rect[::-1]):
        a2, c2, j2 = polygon_properties(pts)
        assert (a2, *c2, j2) == pytest.approx((area, *c, j))
    segs = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    assert polygon_properties(np.array(rect), segs)[2] == pytest.approx(j)

    lo3, hi3 = np.array([0.0, 0.0, 0.0]), np.array([0.3, 0.2, 0.1])
    vol, c3, I3 = box_properties(lo3, hi3)
    corners = np.array([[x, y, z] for x in (0, 0.3) for y in (0, 0.2) for z in (0, 0.1)])
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    tri = np.array([t for q in quads for t in ([q[0], q[1], q[2]], [q[0], q[2], q[3]])])
    for faces in (tri, tri[:, ::-1]):
        v, cm, Im = mesh_properties(corners + [1.0, -2.0, 0.5], faces)
        assert v == pytest.approx(vol) and np.allclose(cm, c3 + [1.0, -2.0, 0.5]) and np.allclose(Im, I3)


def _free_fall_case(dim):
    lo, hi = [0.0] * dim, [2.0] * dim
    body_lo, body_hi = [1.4] * (dim - 1) + [1.2], [1.6] * (dim - 1) + [1.4]
    return {"dim": dim, "dp": 0.05, "precision": "float64", "time": {"end": 0.2, "dt": 1e-3},
            "fluid": [{"min": lo, "max": [0.3] * (dim - 1) + [0.2]}],
            "tank": {"min": lo, "max": hi}, "model": {"name": "bi"}, "output": {"vtk": False},
            "obstacle": [{"name": "box", "min": body_lo, "max": body_hi, "floating": {"density": 500.0}}]}


@pytest.mark.parametrize("dim", [2, 3])
def test_a_body_away_from_the_fluid_falls_freely(dim, tmp_path):
    """Nothing but gravity on it: after n steps of symplectic Euler its velocity is -g t
    exactly and its height falls by g t^2 / 2 plus the scheme's g t dt / 2 (a constant dt);
    it does not turn. (probes.csv holds 9 digits.)"""
    s = wcsph.run(_free_fall_case(dim), output=tmp_path, progress=False)
    rows = list(csv.DictReader(open(tmp_path / "probes.csv")))
    last = rows[-1]
    t, g = float(last["time"]), 9.81
    z = "xyz"[dim - 1]
    assert float(last[f"box_v{z}"]) == pytest.approx(-g * t, rel=1e-8)
    dt = t / s["steps"]
    assert s["steps"] == 200 and float(last[f"box_{z}"]) == pytest.approx(1.3 - 0.5 * g * t * t - 0.5 * g * t * dt,
                                                                          abs=1e-8)
    assert float(last["box_fx"]) == 0.0
    turn = "box_theta" if dim == 2 else "box_omegax"
    assert float(last[turn]) == 0.0


def test_a_box_floats_at_archimedes_draft(tmp_path):
    """A flat box (0.4 x 0.1 m, density 500: draft 0.05 m, metacentric height 0.24 m,
    stable) in hydrostatic_2d_bi at dp = 0.04, released after the fluid has settled for 1 s:
    over the next 3 s its centre stays within dp/2 of the water level (where Archimedes puts
    it: draft = half its height), it drifts less than dp sideways and turns less than 0.05
    rad. (dp = 0.02 over 5 s: within 0.3 dp, drift 0.4 dp; README, "Floating bodies".)

    Without NBVC-PST: with it the box drifts sideways 0.011 or 0.114 m in these 3 s depending
    on the last bits of the compiled code's rounding (a fresh compile or the cached one): the
    shift moves particles next to the body without a reaction on it, and round its convex
    corners (open, README "Floating bodies"). Without it the drift is 0.0005 m."""
    box = {"name": "box", "min": [0.8, 0.45], "max": [1.2, 0.55], "floating": {"density": 500.0, "release": 1.0}}
    gauge = {"name": "level", "kind": "level", "position": [0.3, 0.0]}
    wcsph.run("hydrostatic_2d_bi", output=tmp_path, progress=False,
              overrides=[("dp", 0.04), ("time.end", 4.0), ("output.vtk", False), ("output.probe_interval", 0.05),
                         ("obstacle", [box]), ("probes", [gauge]), ("model.enableShifting", False)])
    rows = [r for r in csv.DictReader(open(tmp_path / "probes.csv")) if float(r["time"]) >= 1.0]
    y = np.array([float(r["box_y"]) for r in rows])
    level = np.array([float(r["level"]) for r in rows])
    x = np.array([float(r["box_x"]) for r in rows])
    theta = np.array([float(r["box_theta"]) for r in rows])
    assert abs(np.mean(y - level)) < 0.02 and np.abs(y - level).max() < 0.04
    assert np.abs(x - 1.0).max() < 0.01 and np.abs(theta).max() < 0.01


@pytest.mark.parametrize("change, key", [
    ({"tank": {"min": [0.0, 0.0], "max": [1.0, 1.0], "floating": {"density": 500.0}}}, "tank.floating"),
    ({"obstacle": [{"min": [0.4, 0.6], "max": [0.6, 0.8], "floating": {"density": 500.0}}]}, "obstacle[0].name"),
    ({"obstacle": [{"name": "b", "min": [0.4, 0.6], "max": [0.6, 0.8], "floating": {}}]}, "obstacle[0].floating"),
    ({"obstacle": [{"name": "b", "min": [0.4, 0.6], "max": [0.6, 0.8],
                    "floating": {"density": 500.0, "mass": 3.0}}]}, "obstacle[0].floating"),
    ({"obstacle": [{"name": "b", "min": [0.4, 0.6], "max": [0.6, 0.8], "floating": {"density": 500.0},
                    "motion": {"kind": "velocity", "velocity": [1.0, 0.0]}}]}, "obstacle[0].floating"),
    ({"polygon": [{"name": "b", "points": [[0.4, 0.6], [0.5, 0.8], [0.6, 0.6]], "floating": {"mass": 2.0}}]},
     "polygon[0].closed"),
    ({"polygon": [{"name": "b", "points": [[0.4, 0.6], [0.6, 0.6], [0.5, 0.8]], "closed": True,
                   "floating": {"mass": 2.0}}]}, "polygon[0].points"),
])
def test_floating_errors_name_the_key(change, key):
    base = {"dim": 2, "dp": 0.1, "time": {"end": 0.1}, "fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.5]}],
            "tank": {"min": [0.0, 0.0], "max": [1.0, 1.0]}}
    with pytest.raises(CaseError, match=key.replace("[", r"\[").replace("]", r"\]")):
        validate(dict(base, **change))


def test_boundary_particle_loads_carry_the_weight_of_the_water():
    """Classic model (Akinci wall particles, Adami wall pressure), hydrostatic_2d after its
    gravity ramp: the tank's load, the reaction of the wall terms on the fluid summed over its
    wall particles (one pass), is the weight of the water within 0.5 % (measured 0.05 %)."""
    from wcsph.config import load

    sim = wcsph.Simulation(load("hydrostatic_2d", [("tank.name", "tank"), ("output.vtk", False)]))
    while sim.t < 1.2:
        sim.step(sim.time_step())
    loads = []
    for _ in range(10):
        sim.step(sim.time_step())
        loads.append(sim.body_loads())
    weight = sim.n_fluid() * sim.mass * 9.81
    assert -np.mean([b["tank_fy"] for b in loads]) == pytest.approx(weight, rel=0.005)
    assert abs(np.mean([b["tank_fx"] for b in loads])) < 1e-3 * weight
