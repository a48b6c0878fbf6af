"""Floating rigid bodies (``floating``): mass properties from the geometry, the rigid-body
step, and a box floating at Archimedes' draft."""
import csv
import math

import numpy as np
import pytest

import wcsph
from wcsph.case.config import _wall_sources, validate
from wcsph.errors import CaseError
from wcsph.boundaries.floating import box_faces, box_properties, mesh_properties, polygon_properties


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

    Without NBVC-PST: with it the box drifts sideways 0.019 m in these 3 s (0.011 or 0.114 m,
    depending on the compiled code's rounding, before the wall corrections stopped acting round
    convex corners): the shift moves particles next to the body without a reaction on it
    (README "Floating bodies"). Without it the drift is 0.00015 m."""
    box = {"name": "box", "min": [0.8, 0.45], "max": [1.2, 0.55], "floating": {"density": 500.0, "release": 1.0}}
    gauge = {"name": "level", "kind": "level", "position": [0.3, 0.0]}
    wcsph.run("hydrostatic_2d_bi", output=tmp_path, progress=False,
              overrides=[("dp", 0.04), ("time.end", 4.0), ("output.vtk", False), ("output.probe_interval", 0.05),
                         ("obstacle", [box]), ("probes", [gauge]), ("model.enableNearBoundaryShifting", False)])
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
    ({"obstacle": [{"name": "b", "min": [0.4, 0.6], "max": [0.6, 0.8],
                    "floating": {"density": 500.0, "friction": -0.1}}]}, "obstacle[0].floating.friction"),
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
    from wcsph.case.config import load

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


@pytest.mark.parametrize("model", ["classic", pytest.param("bi", marks=pytest.mark.validation)])
def test_the_load_passes_visit_only_the_measured_bodies(model):
    """A named obstacle in a tank that is not named: its load is computed over its own wall
    points only (the walls' ``measured``), the tank's points are not visited (their load is
    left as it was), and the obstacle's force and torque are those of a pass over every
    point, to the last bit."""
    from wcsph.case.config import load

    sim = wcsph.Simulation(load("hydrostatic_2d", [
        ("dp", 0.05), ("model.name", model), ("output.vtk", False), ("physics.gravity_ramp_time", 0.0),
        ("obstacle", [{"name": "post", "min": [0.4, 0.0], "max": [0.6, 0.3]}])]))
    for _ in range(5):
        sim.step(sim.time_step())
    w, be = sim.walls, sim.backend
    body, measured = be.to_host(w["body"]), be.to_host(w["measured"])
    assert np.array_equal(measured, (body == 1).astype(measured.dtype)) and 0 < measured.sum() < w.n
    w.add("load", "vector", sim.state.model.dtype, be, scratch=True)
    w["load"] = be.to_device(np.full((2, w.n), np.nan))
    some = sim.body_loads()
    load = be.to_host(w["load"])
    assert np.isnan(load[:, body == 0]).all() and np.isfinite(load[:, body == 1]).all()
    assert abs(some["post_fx"]) > 0 and abs(some["post_fy"]) > 0
    w["measured"] = be.to_device(np.ones(w.n, dtype=measured.dtype))
    every = sim.body_loads()
    assert np.isfinite(be.to_host(w["load"])).all() and every == some


# ------------------------------------------------------------------ constraints and contact
def _body(dim, **kw):
    from wcsph.boundaries.floating import FloatingBody

    inertia = 0.02 if dim == 2 else np.diag([0.02, 0.03, 0.04])
    return FloatingBody("obstacle[0]", dim, 2.0, [0.5] * dim, inertia, **kw)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_held_axis_does_not_move_and_the_free_ones_do(dim):
    """Gravity along the last axis and a sideways force: with the last axis held the body only
    slides (u = F/M t exactly); with the rotation held a torque turns nothing, and in 3D a
    body free to turn about x alone takes alpha_x = T_x / I_xx and nothing about y and z."""
    free = [True] * (dim - 1) + [False]
    b = _body(dim, translation=free, rotation=[False] if dim == 2 else [False, False, False])
    g = [0.0] * (dim - 1) + [-9.81]
    F = [1.0] + [0.0] * (dim - 1)
    T = 0.5 if dim == 2 else np.array([0.5, 0.2, 0.1])
    for _ in range(100):
        b.step(0.01, F, T, g)
    assert b.c[-1] == 0.5 and b.u[-1] == 0.0
    assert b.u[0] == pytest.approx(1.0 / 2.0 * 1.0, rel=1e-12)
    if dim == 2:
        assert b.theta == 0.0 and b.omega == 0.0
        return
    assert np.array_equal(b.R, np.eye(3))
    x_only = _body(3, rotation=[True, False, False])
    x_only.step(0.01, [0.0, 0.0, 0.0], np.array([0.5, 0.2, 0.1]), [0.0, 0.0, 0.0])
    assert x_only.alpha[0] == pytest.approx(0.5 / 0.02, rel=1e-12) and x_only.alpha[1] == x_only.alpha[2] == 0.0


@pytest.mark.parametrize("dim", [2, 3])
def test_a_hinged_body_swings_as_a_compound_pendulum(dim):
    """Hinged L = 0.3 m above its centre and let go 0.05 rad from hanging (3D: the hinge an
    axis along z, ``rotation = [false, false, true]``): the distance to the hinge is kept to
    round-off, and the period is 2 pi sqrt(I_p / (M g L)), I_p = I + M L^2, within 0.2 %
    (symplectic Euler, 2,000 steps a period)."""
    L, M, g = 0.3, 2.0, 9.81
    rot = None if dim == 2 else [False, False, True]
    b = _body(dim, hinge=[0.5, 0.5 + L] + ([0.5] if dim == 3 else []), rotation=rot)
    Izz = 0.02 if dim == 2 else 0.04
    period = 2 * np.pi * np.sqrt((Izz + M * L * L) / (M * g * L))
    dt = period / 2000
    grav = [0.0, -g] + ([0.0] if dim == 3 else [])
    # start 0.05 rad from hanging: turn the body and carry its centre round the hinge
    a0 = 0.05
    r = np.array([L * np.sin(a0), -L * np.cos(a0)] + ([0.0] if dim == 3 else []))
    b.c = b.hinge + r
    if dim == 2:
        b.theta = a0
    else:
        from wcsph.boundaries.floating import _exp

        b.R = _exp(np.array([0.0, 0.0, a0]))
    xs, crossings = [], []
    for k in range(5000):
        b.step(dt, np.zeros(dim), 0.0 if dim == 2 else np.zeros(3), grav)
        xs.append(b.c[0] - 0.5)
        assert np.linalg.norm(b.c - b.hinge) == pytest.approx(L, rel=1e-9)
        if k and xs[-2] > 0 >= xs[-1]:  # crossing the vertical, swinging one way
            crossings.append((k + xs[-2] / (xs[-2] - xs[-1])) * dt)
    measured = np.diff(crossings).mean()
    assert measured == pytest.approx(period, rel=2e-3), (measured, period)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_body_dropped_in_the_tank_lands_on_its_floor(dim, tmp_path):
    """The free-fall case run on until the box has fallen 1.2 m onto the floor: it stops on
    it (the box's bottom on the floor within 1e-9 m, at rest) instead of falling through;
    without the contact it would be 1.2 m below the floor at the end."""
    z, last = _drop(dim, tmp_path)
    assert float(last[f"box_{z}"]) - 0.1 == pytest.approx(0.0, abs=1e-9)
    assert abs(float(last[f"box_v{z}"])) < 1e-12


def _drop(dim, tmp_path, *obstacles):
    """The free-fall case run on to 0.7 s, the box starting 1.2 m above the floor, with the
    water behind a dam at the far end (none of it runs under the box) and ``obstacles``
    added: (the vertical axis' name, the last probes.csv row)."""
    case = _free_fall_case(dim)
    case["time"]["end"] = 0.7
    case["fluid"] = [{"min": [1.8] + [0.0] * (dim - 1), "max": [2.0] * (dim - 1) + [0.2]}]
    case["obstacle"].append({"min": [1.65] + [0.0] * (dim - 1), "max": [1.75] + [2.0] * (dim - 2) + [0.5]})
    case["obstacle"] += list(obstacles)
    case["obstacle"][0].update(min=[0.4] * (dim - 1) + [1.2], max=[0.6] * (dim - 1) + [1.4])
    wcsph.run(case, output=tmp_path, progress=False)
    return "xyz"[dim - 1], list(csv.DictReader(open(tmp_path / "probes.csv")))[-1]


def test_contact_keeps_a_tilted_body_inside_every_face():
    """A turning body thrown at a corner: no wall point ever leaves the tank's faces."""
    from wcsph.boundaries.floating import tank_planes

    b = _body(2)
    pts = np.array([[0.4, 0.6, 0.6, 0.4], [0.4, 0.4, 0.6, 0.6]])
    b.meet(pts, tank_planes({"min": [0.0, 0.0], "max": [1.0, 1.0], "open_top": False}, 2))
    b.u = np.array([3.0, -2.0])
    b.omega = 4.0
    for _ in range(400):
        b.step(0.002, [0.0, 0.0], 0.0, [0.0, -9.81])
        x = b.c[:, None] + np.array([[np.cos(b.theta), -np.sin(b.theta)], [np.sin(b.theta), np.cos(b.theta)]]) @ b.points
        assert x.min() >= -1e-12 and x.max() <= 1.0 + 1e-12


@pytest.mark.parametrize("table,message", [
    ({"density": 500.0, "hinge": [1.5, 1.5], "translation": [True, False]}, "floating.translation"),
    ({"density": 500.0, "rotation": [True, False]}, "floating.rotation"),
    ({"density": 500.0, "hinge": [1.5, 1.5], "rotation": [False]}, "floating.rotation"),
])
def test_a_bad_constraint_names_its_key(table, message):
    case = _free_fall_case(2)
    case["obstacle"][0]["floating"] = table
    with pytest.raises(CaseError, match=message):
        validate(case, "<test>")


# ------------------------------------------------------------------------------ springs
def _hanging(k, c=0.0, line=False, rest=-1.0, dim=2):
    from wcsph.boundaries.floating import FloatingBody

    centre = np.array([1.0, 1.0] if dim == 2 else [1.0, 1.0, 1.0])
    anchor = centre + np.eye(dim)[dim - 1] * 0.5
    spring = {"anchor": anchor, "point": None, "stiffness": k, "rest_length": rest, "damping": c, "line": line}
    inertia = 0.01 if dim == 2 else np.eye(3) * 0.01
    return FloatingBody("box", dim, 2.0, centre, inertia, springs=[spring])


@pytest.mark.parametrize("dim", [2, 3])
def test_a_body_on_a_spring_oscillates_at_its_period_about_m_g_over_k(dim):
    """M = 2 kg hanging from a spring (k = 800 N/m, rest length its starting 0.5 m) under
    gravity: it swings between the start and 2 M g / k below it, with the period
    2 pi sqrt(M/k) (symplectic Euler at dt = T/2000: to 0.1 %); with damping it comes to rest
    M g / k below the start, where the tension carries its weight."""
    M, k, g = 2.0, 800.0, np.array([0.0] * (dim - 1) + [-9.81])
    T = 2 * np.pi * np.sqrt(M / k)
    body, dt = _hanging(k, dim=dim), T / 2000
    z, t = [], []
    for n in range(5000):
        body.step(dt, np.zeros(dim), np.zeros(1 if dim == 2 else 3), g)
        z.append(body.c[-1] - 1.0)
        t.append((n + 1) * dt)
    z = np.array(z)
    assert z.min() == pytest.approx(-2 * M * 9.81 / k, rel=2e-3)
    lows = [t[i] for i in range(1, len(z) - 1) if z[i] < z[i - 1] and z[i] <= z[i + 1]]
    assert np.diff(lows).mean() == pytest.approx(T, rel=1e-3)
    assert np.abs(body.u[:-1]).max() == 0.0 and body.omega is not None
    damped = _hanging(k, c=2 * np.sqrt(k * M), dim=dim)  # critical damping
    for _ in range(20000):
        damped.step(dt, np.zeros(dim), np.zeros(1 if dim == 2 else 3), g)
    assert damped.c[-1] - 1.0 == pytest.approx(-M * 9.81 / k, rel=1e-6)
    assert damped.tensions[0] == pytest.approx(M * 9.81, rel=1e-6)


def test_a_slack_mooring_line_does_not_push():
    """A line longer than the distance to its anchor pulls nothing: the body falls freely
    until the line is taut; a spring of the same rest length pushes it down from the start."""
    g, dt = np.array([0.0, 9.81]), 1e-4  # gravity up, towards the anchor: the line goes slack
    line, spring = _hanging(800.0, line=True, rest=0.6), _hanging(800.0, rest=0.6)
    for _ in range(100):
        for b in (line, spring):
            b.step(dt, np.zeros(2), np.zeros(1), g)
    assert line.tensions[0] == 0.0 and line.u[1] == pytest.approx(9.81 * 100 * dt, rel=1e-12)
    assert spring.tensions[0] < 0 and spring.u[1] < line.u[1]


def test_a_moored_box_in_a_case_reports_its_tension(tmp_path):
    """The ``springs`` table of a case: the body hangs from its anchor (away from the fluid),
    and probes.csv carries the line's tension, which at the start of a free fall from rest is
    zero and then grows with the stretch k g t^2 / 2."""
    case = _free_fall_case(2)
    case["obstacle"][0]["floating"]["springs"] = [{"anchor": [1.5, 1.9], "stiffness": 50.0, "line": True}]
    s = wcsph.run(case, output=tmp_path, progress=False)
    rows = list(csv.DictReader(open(tmp_path / "probes.csv")))
    assert "box_spring0_tension" in rows[0]
    tension = np.array([float(r["box_spring0_tension"]) for r in rows])
    drop = 1.3 - np.array([float(r["box_y"]) for r in rows])
    assert s["status"] == "completed" and tension[0] == 0.0 and tension[-1] > 0
    assert tension[1:] == pytest.approx(50.0 * drop[1:], rel=1e-6, abs=1e-6)  # probes.csv: 9 digits


@pytest.mark.parametrize("dim", [2, 3])
def test_a_body_dropped_on_a_fixed_obstacle_rests_on_it(dim, tmp_path):
    """The drop above, with a fixed obstacle box (top at 0.6 m) under the body: it stops on the
    box's top (within 1e-9 m, at rest) instead of falling through it to the floor."""
    z, last = _drop(dim, tmp_path, {"min": [0.3] * (dim - 1) + [0.0], "max": [0.7] * (dim - 1) + [0.6]})
    assert float(last[f"box_{z}"]) - 0.7 == pytest.approx(0.0, abs=1e-9)
    assert abs(float(last[f"box_v{z}"])) < 1e-12


def test_a_body_thrown_at_a_fixed_block_never_enters_it():
    """A turning body thrown sideways at a fixed box: no wall point is ever inside the box, and
    the body ends on the side it came from."""
    b = _body(2)
    pts = np.array([[0.4, 0.5, 0.6, 0.6, 0.6, 0.5, 0.4, 0.4], [0.4, 0.4, 0.4, 0.5, 0.6, 0.6, 0.6, 0.5]])
    lo, hi = np.array([0.8, 0.0]), np.array([1.2, 1.0])
    b.meet(pts, [], [box_faces(lo, hi)])
    b.u = np.array([3.0, 0.5])
    b.omega = 4.0
    for _ in range(400):
        b.step(0.002, [0.0, 0.0], 0.0, [0.0, 0.0])
        x = b.c[:, None] + np.array([[np.cos(b.theta), -np.sin(b.theta)], [np.sin(b.theta), np.cos(b.theta)]]) @ b.points
        assert not np.any(np.all((x > lo[:, None]) & (x < hi[:, None]), axis=0))
    assert b.c[0] < 0.8 and b.u[0] <= 0.0


#: two fixed obstacles as (N, o) half-spaces (inside where N x < o) and where a body held to
#: vertical motion is put into them: a 45-degree slope (the triangle (0, 0), (1, 0), (0, 1)),
#: entered 0.05 m (vertically) at the body's lower left corner, and a box corner, entered
#: 0.02 m from its side and 0.05 m from its top
HELD_CONTACTS = {
    "slope": ((np.array([[1.0, 1.0], [-1.0, 0.0], [0.0, -1.0]]) * [[math.sqrt(0.5)], [1.0], [1.0]],
               np.array([math.sqrt(0.5), 0.0, 0.0])), [0.3, 0.65], 0.05),
    "corner": (box_faces([0.0, 0.0], [1.0, 0.5]), [0.98, 0.45], 0.05),
}


@pytest.mark.parametrize("wall", ["fixed", "driven"])
@pytest.mark.parametrize("name", sorted(HELD_CONTACTS))
def test_a_body_held_to_vertical_motion_leaves_an_obstacle_upward(name, wall):
    """A box that may only move vertically (no rotation), put into an obstacle and moving into
    it at 1 m/s: the contact lifts it out exactly (its lowest corner back on the slope, or on
    the box's top, not pushed through the box's nearer side, which its held axis cannot move
    along) and takes its speed into the obstacle out. The same whether the obstacle is a
    fixed one (``meet``, ``settle``) or a wall on a path (``Driven``, ``collide``): one
    mechanism."""
    from wcsph.boundaries.floating import Driven, Still, collide

    shape, corner, lift = HELD_CONTACTS[name]
    corner = np.asarray(corner)
    b, pts = _box_body(corner, corner + 0.2, 1.0)
    b.free_t, b.free_r = np.array([0.0, 1.0]), np.array([False])
    b.u = np.array([0.0, -1.0])
    if wall == "fixed":
        b.meet(pts, [], [shape])
        b.settle()
    else:
        b.meet(pts, [])
        collide(b, Driven(Still(2), np.zeros(2), np.zeros((2, 0)), [shape]))
    c0 = corner + 0.1
    assert b.c[0] == c0[0] and b.c[1] == pytest.approx(c0[1] + lift, abs=1e-12)
    N, o = shape
    assert np.all(np.max(N @ b.wall_points() - o[:, None], axis=0) >= -1e-12)  # no point inside
    assert b.u[0] == 0.0 and abs(b.u[1]) < 1e-12 and b.omega == 0.0


def _box_body(lo, hi, mass, dim=2):
    from wcsph.boundaries.floating import FloatingBody, box_properties

    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    vol, c, j = box_properties(lo, hi)
    b = FloatingBody("box", dim, mass, c, mass / vol * j)
    grid = [np.linspace(lo[a], hi[a], 9) for a in range(dim)]
    pts = np.array([p for p in np.array(np.meshgrid(*grid)).reshape(dim, -1).T
                    if np.any(np.isclose(p, lo) | np.isclose(p, hi))]).T  # its surface
    b.box = (lo - c, hi - c)
    return b, pts


@pytest.mark.parametrize("offset", [0.0, 0.05])
def test_two_floating_boxes_meet_inelastically_and_keep_their_momentum(offset):
    """Two boxes (1 and 3 kg, 0.2 m wide) thrown at each other (2 and -1 m/s, no gravity): no
    wall point of one ever enters the other, their momentum stays -1 kg m/s exactly and
    their angular momentum about the origin within 1e-5 of its start (the pushes that part
    them move the centres), and their kinetic energy never grows. Face to face (``offset``
    0) they then move together at -1/4 m/s without turning (a perfectly inelastic contact);
    met off-centre (the second 0.05 m higher) the contact's impulses turn both."""
    from wcsph.boundaries.floating import collide

    a, pa = _box_body([0.2, 0.4], [0.4, 0.6], 1.0)
    b, pb = _box_body([0.8, 0.4 + offset], [1.0, 0.6 + offset], 3.0)
    a.meet(pa, [])
    b.meet(pb, [])
    a.u, b.u = np.array([2.0, 0.0]), np.array([-1.0, 0.0])

    def spin(x):  # angular momentum about the origin
        return x.mass * (x.c[0] * x.u[1] - x.c[1] * x.u[0]) + x.inertia * x.omega

    def energy(x):
        return 0.5 * x.mass * x.u @ x.u + 0.5 * x.inertia * x.omega ** 2

    L0, E = spin(a) + spin(b), energy(a) + energy(b)
    for _ in range(300):
        for body in (a, b):
            body.step(0.001, [0.0, 0.0], 0.0, [0.0, 0.0])
        collide(a, b)
        for p, q in ((a, b), (b, a)):
            x = p.c[:, None] + _rot(p.theta) @ p.points
            y = _rot(q.theta).T @ (x - q.c[:, None])
            assert not np.any(np.all((y > q.box[0][:, None] + 1e-12) & (y < q.box[1][:, None] - 1e-12), axis=0))
        assert a.mass * a.u + b.mass * b.u == pytest.approx([-1.0, 0.0], abs=1e-12)
        assert spin(a) + spin(b) == pytest.approx(L0, abs=1e-5)
        assert energy(a) + energy(b) <= E + 1e-12
        E = energy(a) + energy(b)
    if offset == 0.0:
        assert a.u == pytest.approx([-0.25, 0.0], abs=1e-12) and b.u == pytest.approx([-0.25, 0.0], abs=1e-12)
        assert abs(a.omega) < 1e-12 and abs(b.omega) < 1e-12
    else:
        assert abs(a.omega) > 1.0 and abs(b.omega) > 1.0, (a.omega, b.omega)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_tilted_box_dropped_on_another_falls_flat_on_it(dim):
    """The contact between two floating boxes pushes through its contact points, so it turns
    them: a 0.2 m box (1 kg) tilted by 0.4 rad and dropped onto a wide one (10 kg) lying on the
    floor lands on a corner, falls onto a face and rests on the lower box's top (turned by a
    multiple of 90 degrees within 0.01 rad, its centre 0.1 m above that top within 1e-6 m,
    slower than 1 mm/s: frictionless, the landing leaves it a slow slide, 0.3 mm/s in 3D), the
    lower box undisturbed on the floor. Without the contact's torque it would stay on its
    corner at 0.4 rad."""
    from wcsph.boundaries.floating import collide, tank_planes

    planes = tank_planes({"min": [0.0] * dim, "max": [2.0] * dim, "open_top": True}, dim)
    low, pl = _box_body([0.5] * (dim - 1) + [0.0], [1.5] * (dim - 1) + [0.2], 10.0, dim)
    up, pu = _box_body([0.9] * (dim - 1) + [0.5], [1.1] * (dim - 1) + [0.7], 1.0, dim)
    low.meet(pl, planes)
    up.meet(pu, planes)
    a = 0.4
    if dim == 2:
        up.theta = a
    else:  # about x
        up.R = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])
    g = [0.0] * (dim - 1) + [-9.81]
    zero_t = 0.0 if dim == 2 else np.zeros(3)
    for _ in range(800):
        for b in (low, up):
            b.step(0.001, [0.0] * dim, zero_t, g)
        for _ in range(16):  # as the floating stage sweeps the pairs
            if not collide(low, up):
                break
            low.settle()
            up.settle()
    turned = up.theta if dim == 2 else math.atan2(up.R[2, 1], up.R[1, 1])
    assert abs((turned + math.pi / 4) % (math.pi / 2) - math.pi / 4) < 0.01, turned
    assert up.c[-1] == pytest.approx(0.3, abs=1e-6) and low.c[-1] == pytest.approx(0.1, abs=1e-9)
    assert np.abs(up.u).max() < 1e-3 and np.abs(up.omega).max() < 1e-3


def _rot(theta):
    return np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])


@pytest.mark.parametrize("dim", [2, 3])
def test_a_floating_box_dropped_on_another_stacks_on_it(dim, tmp_path):
    """A light box (density 300) dropped 0.3 m onto a heavier one (density 800) lying on the
    tank's floor, away from the fluid: after 0.6 s the stack rests, the upper box's bottom on
    the lower's top and the lower's on the floor (within 1e-9 m), neither moving (|v| < 1e-9
    m/s: each step's fall is passed on to the floor over the sweeps; measured 1e-14)."""
    case = _free_fall_case(dim)
    case["time"]["end"] = 0.6
    case["fluid"] = [{"min": [1.8] + [0.0] * (dim - 1), "max": [2.0] * (dim - 1) + [0.2]}]
    case["obstacle"] = [
        {"name": "low", "min": [0.4] * (dim - 1) + [0.0], "max": [0.8] * (dim - 1) + [0.2], "floating": {"density": 800.0}},
        {"name": "up", "min": [0.5] * (dim - 1) + [0.5], "max": [0.7] * (dim - 1) + [0.7], "floating": {"density": 300.0}},
        {"min": [1.65] + [0.0] * (dim - 1), "max": [1.75] + [2.0] * (dim - 2) + [0.5]}]
    wcsph.run(case, output=tmp_path, progress=False)
    last = list(csv.DictReader(open(tmp_path / "probes.csv")))[-1]
    z = "xyz"[dim - 1]
    assert float(last[f"low_{z}"]) == pytest.approx(0.1, abs=1e-9)
    assert float(last[f"up_{z}"]) == pytest.approx(0.3, abs=1e-9)
    assert abs(float(last[f"low_v{z}"])) < 1e-9 and abs(float(last[f"up_v{z}"])) < 1e-9


@pytest.mark.validation  # 3D, 15 k particles to t = 2.2 s: about three minutes here
def test_the_3d_floating_box_demonstration_floats(tmp_path):
    """``floating_box_waves_3d`` (a box of half water's density across a 3D flume, free to heave
    and pitch, released at 1 s) until the first waves reach it: in the still water after its
    release its centre stays within dp/2 of the still level (Archimedes: draft = half its
    height; measured 0.3 dp low) and it pitches less than 2 degrees; no fluid particle is
    inside it at the end."""
    wcsph.run("floating_box_waves_3d", output=tmp_path, progress=False,
              overrides=[("time.end", 2.2), ("output.interval", 2.2)])
    rows = [r for r in csv.DictReader(open(tmp_path / "probes.csv")) if 1.2 <= float(r["time"]) <= 2.2]
    z = np.array([float(r["box_z"]) for r in rows])
    pitch = np.degrees(np.arcsin(np.clip([float(r["box_R02"]) for r in rows], -1, 1)))
    assert abs(z.mean() - 0.4) < 0.02 and np.abs(z - 0.4).max() < 0.03, (z.mean(), z.min(), z.max())
    assert np.abs(pitch).max() < 2.0
    import meshio

    last = sorted(tmp_path.glob("fluid_*.vtu"))[-1]
    x = meshio.read(last).points
    R = np.array([[float(rows[-1][f"box_R{a}{b}"]) for b in range(3)] for a in range(3)])
    centre = np.array([float(rows[-1][k]) for k in ("box_x", "box_y", "box_z")])
    local = (x - centre) @ R  # body frame: R maps body to world
    inside = np.all(np.abs(local) < np.array([0.2, 0.12, 0.08]) - 0.01, axis=1)
    assert not inside.any(), int(inside.sum())


@pytest.mark.parametrize("surface", ["floor", "block"])
@pytest.mark.parametrize("dim", [2, 3])
def test_a_tilted_box_dropped_on_the_floor_falls_flat(dim, surface):
    """The contact with a tank face pushes through the contact point, so it turns the body: a
    box tilted by 0.4 rad and dropped lands on a corner and falls onto a face, ending at rest
    with its face on the floor (turned by a multiple of 90 degrees, within 0.01 rad; its lowest
    point on the floor within 1e-9 m). Without the contact's torque it would stay balanced on
    its corner at 0.4 rad. The same on a fixed obstacle box."""
    from wcsph.boundaries.floating import tank_planes

    b = _body(dim)
    lo, hi = 0.4, 0.6
    corners = np.array(np.meshgrid(*[[lo, hi]] * dim, indexing="ij")).reshape(dim, -1)
    if surface == "floor":
        b.meet(corners, tank_planes({"min": [0.0] * dim, "max": [1.0] * dim, "open_top": True}, dim))
    else:  # a fixed obstacle box below the body, its top at the same height as the floor
        b.meet(corners, [], [box_faces([-1.0] * dim, [2.0] * (dim - 1) + [0.0])])
    a = 0.4
    if dim == 2:
        b.theta = a
    else:  # about x: the body's y-z face tilted
        b.R = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])
    g = [0.0] * (dim - 1) + [-9.81]
    zero_t = 0.0 if dim == 2 else np.zeros(3)
    for _ in range(3000):
        b.step(0.001, [0.0] * dim, zero_t, g)
    if dim == 2:
        turned = b.theta
        R = np.array([[np.cos(b.theta), -np.sin(b.theta)], [np.sin(b.theta), np.cos(b.theta)]])
    else:
        turned = math.atan2(b.R[2, 1], b.R[1, 1])
        R = b.R
    off = abs((turned + math.pi / 4) % (math.pi / 2) - math.pi / 4)
    assert off < 0.01, turned
    x = b.c[:, None] + R @ b.points
    assert x[-1].min() == pytest.approx(0.0, abs=1e-9)
    assert np.abs(b.u).max() < 1e-3 and np.abs(b.omega).max() < 1e-2


def _slope(dim, theta):
    """Gravity tilted by theta about the last axis: a floor that is a slope of angle theta."""
    g = np.zeros(dim)
    g[0], g[-1] = 9.81 * np.sin(theta), -9.81 * np.cos(theta)
    return g


@pytest.mark.parametrize("surface", ["floor", "block"])
@pytest.mark.parametrize("mu", [0.0, 0.2, 0.5])
@pytest.mark.parametrize("dim", [2, 3])
def test_a_box_on_a_slope_sticks_or_slides_as_coulomb_says(dim, mu, surface):
    """A box resting flat on a slope of 0.3 rad (gravity tilted), for 0.5 s: with mu = 0.5
    (> tan 0.3 = 0.31) it stays (speed below 1e-12 m/s), with mu = 0.2 it slides with
    g (sin - mu cos) and frictionless with g sin, to 1e-9 of the exact speed; it does not
    turn (1e-12 rad/s) nor leave the surface. The same on a fixed obstacle box."""
    from wcsph.boundaries.floating import FloatingBody, tank_planes

    inertia = 0.02 if dim == 2 else np.diag([0.02, 0.03, 0.04])
    b = FloatingBody("box", dim, 2.0, [0.5] * (dim - 1) + [0.1], inertia, friction=mu)
    lo, hi = [0.4] * (dim - 1) + [0.0], [0.6] * (dim - 1) + [0.2]
    corners = np.array(np.meshgrid(*[[a, c] for a, c in zip(lo, hi)], indexing="ij")).reshape(dim, -1)
    if surface == "floor":
        b.meet(corners, tank_planes({"min": [-5.0] * (dim - 1) + [0.0], "max": [5.0] * dim, "open_top": True}, dim))
    else:
        b.meet(corners, [], [box_faces([-5.0] * dim, [5.0] * (dim - 1) + [0.0])])
    theta, dt, steps = 0.3, 1e-3, 500
    zero_t = 0.0 if dim == 2 else np.zeros(3)
    for _ in range(steps):
        b.step(dt, np.zeros(dim), zero_t, _slope(dim, theta))
    exact = max(0.0, 9.81 * (np.sin(theta) - mu * np.cos(theta))) * steps * dt
    assert b.u[0] == pytest.approx(exact, abs=1e-9 * max(exact, 1.0))
    assert np.abs(b.u[1:]).max() < 1e-12 and np.abs(b.omega).max() < 1e-12
    assert b.c[-1] == pytest.approx(0.1, abs=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_friction_between_two_boxes_takes_the_lesser_coefficient(dim):
    """A light box (1 kg, mu = 0.2) on a heavy one (10 kg, mu = 0.9) lying on a slope of
    0.3 rad: the heavy one sticks to the floor (its own mu), the light one slides on it with
    g (sin - 0.2 cos) (the lesser of the two), within 0.5 % of the exact speed over 0.5 s
    (measured +0.27 %: the pair's contact and the floor's are solved one after the other, as
    the floating stage sweeps them, not as one system; with the heavy box's mu the light one
    would have stuck)."""
    from wcsph.boundaries.floating import collide, tank_planes

    planes = tank_planes({"min": [-5.0] * (dim - 1) + [0.0], "max": [5.0] * dim, "open_top": True}, dim)
    low, pl = _box_body([0.0] * (dim - 1) + [0.0], [2.0] * (dim - 1) + [0.2], 10.0, dim)
    up, pu = _box_body([0.9] * (dim - 1) + [0.2], [1.1] * (dim - 1) + [0.4], 1.0, dim)
    low.friction, up.friction = 0.9, 0.2
    low.meet(pl, planes)
    up.meet(pu, planes)
    theta, dt, steps = 0.3, 1e-3, 500
    zero_t = 0.0 if dim == 2 else np.zeros(3)
    g = _slope(dim, theta)
    for _ in range(steps):
        for b in (low, up):
            b.step(dt, np.zeros(dim), zero_t, g)
        for _ in range(16):  # as the floating stage sweeps the pairs
            if not collide(low, up):
                break
            low.settle()
            up.settle()
    exact = 9.81 * (np.sin(theta) - 0.2 * np.cos(theta)) * steps * dt
    assert up.u[0] == pytest.approx(exact, rel=5e-3)
    assert np.abs(low.u).max() < 1e-9 and np.abs(low.omega).max() < 1e-9
    assert up.c[-1] == pytest.approx(0.3, abs=1e-6)


def test_a_case_gives_its_body_the_friction_coefficient():
    """``floating.friction`` in a case reaches the body (0 when not given)."""
    from wcsph.boundaries.floating import body_of

    base = {"dim": 2, "dp": 0.1, "time": {"end": 0.1}, "fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.5]}],
            "tank": {"min": [0.0, 0.0], "max": [1.0, 1.0]}}
    for given, want in (({"density": 500.0, "friction": 0.3}, 0.3), ({"density": 500.0}, 0.0)):
        case = validate(dict(base, obstacle=[{"name": "b", "min": [0.4, 0.6], "max": [0.6, 0.8], "floating": given}]))
        assert body_of("obstacle[0]", case["obstacle"][0], 2).friction == want


def test_convex_faces_of_boxes_polygons_and_meshes():
    """The half-space form of a convex shape: a square's four faces, a hexagon's six (either
    orientation), a cube mesh's six (its twelve triangles merged by plane), each point of the
    shape inside or on every face; a concave polygon and a concave mesh have none."""
    from wcsph.boundaries.floating import convex_faces

    square = np.array([[-1.0, 1.0, 1.0, -1.0], [-0.5, -0.5, 0.5, 0.5]])
    N, o = convex_faces(square)
    assert len(o) == 4 and np.allclose(sorted(o), [0.5, 0.5, 1.0, 1.0])
    angles = np.arange(6) * np.pi / 3
    hexagon = np.array([np.cos(angles), np.sin(angles)])
    for pts in (hexagon, hexagon[:, ::-1]):
        N, o = convex_faces(pts)
        assert len(o) == 6 and np.allclose(o, np.cos(np.pi / 6))
        assert np.all(N @ pts <= o[:, None] + 1e-12)
    dart = np.array([[-1.0, 0.0, 1.0, 0.0], [-1.0, -0.2, -1.0, 1.0]])  # concave at (0, -0.2)
    assert convex_faces(dart - dart.mean(axis=1, keepdims=True)) is None
    cube = np.array(np.meshgrid([-1.0, 1.0], [-1.0, 1.0], [-1.0, 1.0], indexing="ij")).reshape(3, -1)
    tris = []
    for a in range(3):  # two triangles per face, by the corners with coordinate a = +-1
        for side in (-1.0, 1.0):
            idx = [k for k in range(8) if cube[a, k] == side]
            tris += [[idx[0], idx[1], idx[3]], [idx[0], idx[3], idx[2]]]
    N, o = convex_faces(cube, np.array(tris))
    assert len(o) == 6 and np.allclose(o, 1.0) and np.allclose(np.abs(N).sum(axis=1), 1.0)
    dented = cube.copy()
    dented[:, 7] *= 0.5  # a corner pushed in: concave
    assert convex_faces(dented, np.array(tris)) is None


def _polygon_body(points, mass):
    """A floating convex polygon (dim 2) with wall points along its edges."""
    from wcsph.boundaries.floating import FloatingBody, convex_faces, polygon_properties

    pts = np.asarray(points, dtype=float).T
    area, c, j = polygon_properties(pts.T)
    b = FloatingBody("polygon", 2, mass, c, mass / area * j)
    b.hull = convex_faces(pts - c[:, None])
    edges = [pts[:, k][:, None] + np.outer(pts[:, (k + 1) % pts.shape[1]] - pts[:, k], np.linspace(0, 1, 8, endpoint=False))
             for k in range(pts.shape[1])]
    return b, np.concatenate(edges, axis=1)


@pytest.mark.parametrize("offset", [0.0, 0.07])
def test_a_box_and_a_hexagon_meet_and_keep_their_momentum(offset):
    """A box (1 kg) thrown at a floating hexagon (3 kg; no gravity): no wall point of either
    ever enters the other's convex shape (the box's faces, the hexagon's six), their momentum
    stays -1 kg m/s exactly and their angular momentum about the origin within 5e-3 (the
    impulses keep it; the pushes that part them along a slanted face move the centres across
    their relative velocity: measured 1.1e-3 head on, 1e-5 off-centre), their kinetic
    energy never grows; met off-centre the contact turns both."""
    from wcsph.boundaries.floating import collide

    a, pa = _box_body([0.2, 0.4], [0.4, 0.6], 1.0)
    angles = np.arange(6) * np.pi / 3
    b, pb = _polygon_body(np.array([0.9 + 0.12 * np.cos(angles), 0.5 + offset + 0.12 * np.sin(angles)]).T, 3.0)
    a.meet(pa, [])
    b.meet(pb, [])
    a.u, b.u = np.array([2.0, 0.0]), np.array([-1.0, 0.0])

    def spin(x):
        return x.mass * (x.c[0] * x.u[1] - x.c[1] * x.u[0]) + x.inertia * x.omega

    def energy(x):
        return 0.5 * x.mass * x.u @ x.u + 0.5 * x.inertia * x.omega ** 2

    L0, E = spin(a) + spin(b), energy(a) + energy(b)
    met = False
    for _ in range(300):
        for body in (a, b):
            body.step(0.001, [0.0, 0.0], 0.0, [0.0, 0.0])
        met = collide(a, b) or met
        for p, q in ((a, b), (b, a)):
            N, o = q.faces()
            y = _rot(q.theta).T @ (p.c[:, None] + _rot(p.theta) @ p.points - q.c[:, None])
            assert not np.any(np.all(o[:, None] - N @ y > 1e-12, axis=0))
        assert a.mass * a.u + b.mass * b.u == pytest.approx([-1.0, 0.0], abs=1e-12)
        assert spin(a) + spin(b) == pytest.approx(L0, abs=5e-3)
        assert energy(a) + energy(b) <= E + 1e-12
        E = energy(a) + energy(b)
    assert met
    if offset:
        assert abs(a.omega) > 0.5 and abs(b.omega) > 0.1, (a.omega, b.omega)


def test_a_convex_polygon_case_body_holds_others_out_and_a_concave_one_by_its_pieces():
    """A floating polygon of a case gets its faces (a convex one) or none and its convex
    pieces (a concave one: the dart, two triangles), which ``shapes`` gives either way."""
    from wcsph.boundaries.floating import body_of

    base = {"dim": 2, "dp": 0.1, "time": {"end": 0.1}, "fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.5]}],
            "tank": {"min": [0.0, 0.0], "max": [1.0, 1.0]}}
    for pts, convex in (([[0.4, 0.6], [0.5, 0.8], [0.6, 0.6]], True),  # clockwise, as a floating polygon runs
                        ([[0.4, 0.6], [0.5, 0.8], [0.6, 0.6], [0.5, 0.65]], False)):
        case = validate(dict(base, polygon=[{"name": "b", "points": pts, "closed": True, "floating": {"mass": 2.0}}]))
        body = body_of("polygon[0]", case["polygon"][0], 2)
        assert (body.faces() is not None) == convex
        assert len(body.shapes()) == (1 if convex else 2)


def _in_polygon(x, pts):
    from matplotlib.path import Path

    return Path(np.asarray(pts, dtype=float)).contains_points(np.asarray(x).T)


L_SHAPE = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]]
STAR = [[np.cos(a) * r, np.sin(a) * r] for a, r in zip(np.arange(10) * np.pi / 5, [1.0, 0.4] * 5)]


@pytest.mark.parametrize("pts,pieces", [(L_SHAPE, 2), (L_SHAPE[::-1], 2), (STAR, None),
                                        ([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], 1)])
def test_convex_pieces_cover_the_polygon_and_expose_its_own_edges(pts, pieces):
    """``convex_pieces``: the pieces are convex, cover the polygon and nothing else (every
    point of a grid over it is inside the polygon exactly when inside one piece), the faces
    marked exposed lie on the polygon's edges and add up to its perimeter; an L is two
    pieces either way round, a square one, a five-pointed star at most its ten triangles."""
    from wcsph.boundaries.floating import convex_pieces

    got = convex_pieces(np.asarray(pts, dtype=float).T)
    assert got is not None and (len(got) == pieces if pieces else 2 <= len(got) <= 8)
    v = np.asarray(pts, dtype=float)
    g = np.stack(np.meshgrid(np.linspace(v[:, 0].min() - 0.1, v[:, 0].max() + 0.1, 97),
                             np.linspace(v[:, 1].min() - 0.1, v[:, 1].max() + 0.1, 89))).reshape(2, -1)
    count = sum(np.all(N @ g < o[:, None] - 1e-9, axis=0).astype(int) for N, o, _ in got)
    assert np.all(count <= 1)  # pieces do not overlap
    inside = _in_polygon(g, pts)
    edge_free = np.array([min(np.min(np.abs(N @ p - o)) for N, o, _ in got) > 1e-6 for p in g.T])
    assert np.array_equal((count == 1)[edge_free], inside[edge_free])
    perimeter = sum(np.linalg.norm(v[(k + 1) % len(v)] - v[k]) for k in range(len(v)))
    exposed = 0.0
    for N, o, out in got:
        assert len(N) == len(o) == len(out) and np.allclose(np.linalg.norm(N, axis=1), 1.0)
        for f in np.flatnonzero(out):  # the length of the piece's face f: its extent along the face
            corners = [p for p in v if abs(N[f] @ p - o[f]) < 1e-9 and np.all(N @ p <= o + 1e-9)]
            t = np.array([N[f][1], -N[f][0]])
            exposed += np.ptp([t @ p for p in corners])
    assert exposed == pytest.approx(perimeter, rel=1e-9)


def test_a_box_dropped_into_a_fixed_cup_rests_on_its_inner_floor():
    """A fixed concave polygon (a cup, open on top: its floor 0.1 m thick at y = 0.1-0.2, walls
    at x = 0-0.1 and 0.9-1.0) holds a falling box out of it as a convex obstacle is held
    (``wall_contacts`` gives its convex pieces): the box, dropped inside the cup, never has a
    point inside the cup's solid and comes to rest on its inner floor (within 1e-9 m)."""
    from wcsph.boundaries.floating import FloatingBody, wall_contacts

    cup = [[0.0, 0.1], [1.0, 0.1], [1.0, 0.8], [0.9, 0.8], [0.9, 0.2], [0.1, 0.2], [0.1, 0.8], [0.0, 0.8]]
    case = validate({"dim": 2, "dp": 0.1, "time": {"end": 0.1}, "fluid": [{"min": [1.2, 0.0], "max": [1.5, 0.3]}],
                     "tank": {"min": [-0.5, 0.0], "max": [1.6, 2.0]},
                     "polygon": [{"points": cup[::-1], "closed": True}]})  # clockwise, the fluid outside
    _, blocks, _ = wall_contacts(_wall_sources(case), np.zeros((2, 0)), np.zeros(0, dtype=int))
    assert len(blocks) >= 3 and all(len(b) == 3 for b in blocks)
    b = FloatingBody("box", 2, 2.0, [0.5, 0.6], 2.0 * (0.2 ** 2 + 0.2 ** 2) / 12.0)
    corners = np.array([0.5, 0.6])[:, None] + np.array([[-0.1, 0.1, 0.1, -0.1, 0.0, 0.1, 0.0, -0.1],
                                                         [-0.1, -0.1, 0.1, 0.1, -0.1, 0.0, 0.1, 0.0]])
    b.meet(corners, [], blocks)
    b.u = np.array([0.0, -1.0])
    for _ in range(400):
        b.step(0.002, [0.0, 0.0], 0.0, [0.0, -9.81])
        x = b.c[:, None] + _rot(b.theta) @ b.points
        on_edge = np.array([min(np.min(np.abs(N @ p - o)) for N, o, _ in blocks) < 1e-9 for p in x.T])
        assert not np.any(_in_polygon(x, cup) & ~on_edge)
    assert b.c[1] - 0.1 == pytest.approx(0.2, abs=1e-9) and abs(b.u[1]) < 1e-9 and b.c[0] == pytest.approx(0.5)


def test_a_box_thrown_into_a_floating_l_stays_out_of_it_and_keeps_the_momentum():
    """A box (1 kg) thrown into the notch of a floating L (3 kg; no gravity), turning: no
    wall point of the box ever enters the L (its two convex pieces), their momentum stays as
    it was to round-off and their kinetic energy never grows."""
    from wcsph.boundaries.floating import FloatingBody, collide, convex_pieces, polygon_properties

    a, pa = _box_body([1.4, 1.4], [1.6, 1.6], 1.0)
    L = np.asarray(L_SHAPE, dtype=float).T
    area, c, j = polygon_properties(L.T)
    b = FloatingBody("L", 2, 3.0, c, 3.0 / area * j)
    b.pieces = convex_pieces(L - c[:, None])
    edges = [L[:, k][:, None] + np.outer(L[:, (k + 1) % 6] - L[:, k], np.linspace(0, 1, 12, endpoint=False))
             for k in range(6)]
    a.meet(pa, [])
    b.meet(np.concatenate(edges, axis=1), [])
    a.u, a.omega = np.array([-1.5, -1.0]), 2.0

    def energy(x):
        return 0.5 * x.mass * x.u @ x.u + 0.5 * x.inertia * x.omega ** 2

    P0, E = a.mass * a.u + b.mass * b.u, energy(a) + energy(b)
    met = False
    for _ in range(300):
        for body in (a, b):
            body.step(0.002, [0.0, 0.0], 0.0, [0.0, 0.0])
        met = collide(a, b) or met
        x = a.c[:, None] + _rot(a.theta) @ a.points
        y = _rot(b.theta).T @ (x - b.c[:, None]) + c[:, None]  # in the L's frame at the start
        inside = _in_polygon(y, L_SHAPE)
        depth = np.array([min(np.min(np.abs(N @ (p - c) - o)) for N, o, _ in b.pieces) for p in y.T])
        assert not np.any(inside & (depth > 1e-9))
        assert a.mass * a.u + b.mass * b.u == pytest.approx(P0, abs=1e-12)
        e = energy(a) + energy(b)
        assert e <= E * (1 + 1e-12)
        E = e
    assert met


@pytest.mark.parametrize("mu", [0.0, 0.5])
def test_a_box_on_a_fixed_wedge_slides_off_or_stays_by_its_friction(mu):
    """A fixed closed polygon, clockwise (a body: the fluid outside; a wedge whose right face
    slopes at 0.3 rad), holds a floating box
    out of it as the tank's faces do (``wall_contacts``): the box, turned to lie flat on the
    slope and released on it, slides down at g sin 0.3 frictionless (to 1e-9 of the exact
    speed after 0.3 s) and stays with mu = 0.5 > tan 0.3; it never has a point inside the
    wedge, nor turns."""
    from wcsph.boundaries.floating import FloatingBody, wall_contacts

    theta = 0.3
    case = validate({"dim": 2, "dp": 0.1, "time": {"end": 0.1}, "fluid": [{"min": [0.0, 0.0], "max": [0.5, 0.5]}],
                     "tank": {"min": [0.0, 0.0], "max": [6.0, 3.0]},
                     "polygon": [{"points": [[1.0, 0.0], [1.0, 4.0 * np.tan(theta)], [5.0, 0.0]], "closed": True}]})
    _, blocks, _ = wall_contacts(_wall_sources(case), np.zeros((2, 0)), np.zeros(0, dtype=int))
    assert len(blocks) == 1 and len(blocks[0][1]) == 3
    t = np.array([np.cos(theta), -np.sin(theta)])  # down the slope
    n = np.array([np.sin(theta), np.cos(theta)])  # out of the slope
    foot = np.array([1.0, 4.0 * np.tan(theta)]) + 1.5 * t
    centre = foot + 0.1 * n
    b = FloatingBody("box", 2, 2.0, centre, 2.0 * (0.2 ** 2 + 0.2 ** 2) / 12.0, friction=mu)
    corners = centre[:, None] + np.array([[-0.1, 0.1, 0.1, -0.1], [-0.1, -0.1, 0.1, 0.1]])
    b.meet(corners, [], blocks)
    b.theta = -theta
    for _ in range(300):
        b.step(0.001, [0.0, 0.0], 0.0, [0.0, -9.81])
        x = b.c[:, None] + _rot(b.theta) @ b.points
        N, o = blocks[0]
        assert not np.any(np.all(o[:, None] - N @ x > 1e-12, axis=0))
    speed = float(b.u @ t)
    exact = max(0.0, 9.81 * (np.sin(theta) - mu * np.cos(theta))) * 0.3
    assert speed == pytest.approx(exact, abs=1e-9 * max(exact, 1.0))
    assert abs(float(b.u @ n)) < 1e-9 and abs(b.omega) < 1e-9


def _voxel_mesh(edges, solid):
    """The closed, outward-oriented triangle surface of a union of boxes: the cells of the
    grid whose planes along each axis are ``edges`` (three lists) where ``solid`` (a boolean
    array, one entry per cell) is true. (vertices (3, V), triangles (F, 3))."""
    verts, tris, index = [], [], {}

    def vertex(p):
        key = tuple(round(c, 12) for c in p)
        if key not in index:
            index[key] = len(verts)
            verts.append(key)
        return index[key]

    shape = solid.shape
    for cell in np.ndindex(shape):
        if not solid[cell]:
            continue
        for a in range(3):
            for side in (0, 1):
                nb = list(cell)
                nb[a] += 1 if side else -1
                if 0 <= nb[a] < shape[a] and solid[tuple(nb)]:
                    continue  # an inner face
                b, c = (a + 1) % 3, (a + 2) % 3
                corners = []
                for ub, uc in ((0, 0), (1, 0), (1, 1), (0, 1)):  # counter-clockwise about +a
                    p = [0.0] * 3
                    p[a] = edges[a][cell[a] + side]
                    p[b] = edges[b][cell[b] + ub]
                    p[c] = edges[c][cell[c] + uc]
                    corners.append(vertex(p))
                if not side:
                    corners = corners[::-1]  # facing -a
                tris += [corners[:3], [corners[0], corners[2], corners[3]]]
    return np.array(verts, dtype=float).T, np.array(tris, dtype=np.int64)


#: a cup, 0.5 x 0.5 x 0.6 m, walls and floor 0.1 and 0.2 m thick, open at the top
CUP_EDGES = [[0.25, 0.35, 0.65, 0.75], [0.25, 0.35, 0.65, 0.75], [0.0, 0.2, 0.6]]
CUP_SOLID = np.ones((3, 3, 2), dtype=bool)
CUP_SOLID[1, 1, 1] = False


def _in_cup(x):
    e = CUP_EDGES
    inside = [(x[a] > e[a][0]) & (x[a] < e[a][-1]) for a in range(3)]
    hollow = (x[0] > e[0][1]) & (x[0] < e[0][2]) & (x[1] > e[1][1]) & (x[1] < e[1][2]) & (x[2] > e[2][1])
    return inside[0] & inside[1] & inside[2] & ~hollow


def test_a_concave_mesh_knows_its_inside_and_the_nearest_way_out():
    """``MeshShape`` of the cup: 2,000 random points are inside its solid or not as the boxes
    say (the hollow outside); a point in a wall or the floor leaves through
    the nearest face, at its distance; the cup's volume from the same triangles is its own."""
    from wcsph.boundaries.floating import MeshShape, mesh_properties

    v, t = _voxel_mesh(CUP_EDGES, CUP_SOLID)
    assert mesh_properties(v.T, t)[0] == pytest.approx(0.5 * 0.5 * 0.6 - 0.3 * 0.3 * 0.4, rel=1e-12)
    shape = MeshShape(v, t)
    rng = np.random.default_rng(3)
    x = rng.uniform([0.2, 0.2, -0.05], [0.8, 0.8, 0.65], size=(2000, 3)).T
    assert np.array_equal(shape.inside(x), _in_cup(x))
    from wcsph.boundaries.floating import _exp

    R = _exp(np.array([0.3, -0.5, 0.7]))  # turned: no face along the ray or a grid axis
    assert np.array_equal(MeshShape(R @ v, t).inside(R @ x), _in_cup(x))
    fine = [np.round(np.arange(e[0], e[-1] + 1e-9, 0.025), 12) for e in CUP_EDGES]  # 6,976 triangles
    solid = _in_cup(np.array(np.meshgrid(*[0.5 * (f[1:] + f[:-1]) for f in fine], indexing="ij")).reshape(3, -1))
    big = MeshShape(*_voxel_mesh(fine, solid.reshape([len(f) - 1 for f in fine])))
    assert big.a.shape[1] > 5000 and np.array_equal(big.inside(x), _in_cup(x))
    inner = x[:, _in_cup(x)]  # the same surface in 76 times the triangles: the same way out
    assert np.allclose(big.nearest(inner)[1], shape.nearest(inner)[1], atol=1e-12)
    points = np.array([[0.5, 0.5, 0.05], [0.5, 0.5, 0.17], [0.27, 0.5, 0.4], [0.5, 0.72, 0.5], [0.3, 0.3, 0.1]]).T
    q, d = shape.nearest(points)
    assert d == pytest.approx([0.05, 0.03, 0.02, 0.03, 0.05], abs=1e-12)
    assert np.allclose(q[:, :4].T, [[0.5, 0.5, 0.0], [0.5, 0.5, 0.2], [0.25, 0.5, 0.4], [0.5, 0.75, 0.5]], atol=1e-12)
    hit = shape.push(points, 1e-12)
    assert hit[0].all() and hit[1] == pytest.approx(0.05) and abs(hit[2] @ [0.0, 0.0, 1.0]) == pytest.approx(1.0)
    assert shape.push(np.array([[0.5], [0.5], [0.4]]), 1e-12) is None  # in the hollow


def test_a_box_dropped_into_a_fixed_3d_cup_mesh_rests_on_its_inner_floor(tmp_path):
    """The drop above in 3D into a fixed concave wall mesh (the cup, from an STL file): the
    box falls into the hollow and stops on its inner floor (the box's bottom at 0.2 m within
    1e-9 m, at rest), where without the mesh's contact it would pass through to the tank's
    floor."""
    import meshio

    v, t = _voxel_mesh(CUP_EDGES, CUP_SOLID)
    path = tmp_path / "cup.stl"
    meshio.write(path, meshio.Mesh(v.T, [("triangle", t)]))
    case = _free_fall_case(3)
    case["time"]["end"] = 0.7
    case["fluid"] = [{"min": [1.8, 0.0, 0.0], "max": [2.0, 2.0, 0.2]}]
    case["obstacle"].append({"min": [1.65, 0.0, 0.0], "max": [1.75, 2.0, 0.5]})
    case["obstacle"][0].update(min=[0.4, 0.4, 1.2], max=[0.6, 0.6, 1.4])
    case["walls"] = [{"mesh": str(path)}]
    wcsph.run(case, output=tmp_path / "out", progress=False)
    last = list(csv.DictReader(open(tmp_path / "out" / "probes.csv")))[-1]
    assert float(last["box_z"]) - 0.1 == pytest.approx(0.2, abs=1e-9)
    assert abs(float(last["box_vz"])) < 1e-12
    assert float(last["box_x"]) == pytest.approx(0.5, abs=1e-9) and float(last["box_y"]) == pytest.approx(0.5, abs=1e-9)


def test_a_box_thrown_into_a_floating_3d_l_mesh_stays_out_of_it_and_keeps_the_momentum():
    """The 2D L test in 3D: a box (1 kg) thrown, turning, into the notch of a floating L-shaped
    prism (3 kg, a concave closed mesh; no gravity): no wall point of the box ever enters the
    L's solid by more than round-off, their momentum stays as it was and their kinetic energy
    never grows."""
    from wcsph.boundaries.floating import MeshShape, body_of

    edges = [[0.0, 1.0, 2.0], [0.0, 1.0, 2.0], [0.0, 1.0]]
    solid = np.array([[[True], [True]], [[True], [False]]])  # the cells (0,0), (0,1), (1,0): an L in x, y
    v, t = _voxel_mesh(edges, solid)
    b = body_of("L", {"floating": {"density": 1.0, "mass": 0.0, "centre": None, "inertia": 0.0, "release": 0.0,
                                    "added_mass": 0.0, "translation": None, "rotation": None, "hinge": None,
                                    "springs": [], "friction": 0.0}}, 3, (v, t))
    assert b.mass == pytest.approx(3.0) and b.hull is None and isinstance(b.shapes()[0], MeshShape)
    a, pa = _box_body([1.4, 1.4, 0.4], [1.6, 1.6, 0.6], 1.0, dim=3)
    grid = np.linspace(0.0, 1.0, 7)
    surface = np.array([p for p in np.array(np.meshgrid(*[np.linspace(0, 2, 13)] * 2 + [grid])).reshape(3, -1).T
                        if solid[min(int(p[0]), 1), min(int(p[1]), 1), 0]
                        and (np.isclose(p[2], 0) or np.isclose(p[2], 1) or np.isclose(p[0], 0) or np.isclose(p[1], 0)
                             or np.isclose(p[0], 2) or np.isclose(p[1], 2) or (p[0] >= 1 and np.isclose(p[1], 1))
                             or (p[1] >= 1 and np.isclose(p[0], 1)))]).T
    a.meet(pa, [])
    b.meet(surface, [])
    a.u, a.omega = np.array([-1.5, -1.0, 0.0]), np.array([0.0, 0.0, 2.0])
    from wcsph.boundaries.floating import collide

    def energy(x):
        return 0.5 * x.mass * x.u @ x.u + 0.5 * x.omega @ (x.R @ x.inertia @ x.R.T) @ x.omega

    P0, E = a.mass * a.u + b.mass * b.u, energy(a) + energy(b)
    met = False
    shape = MeshShape(v, t)
    for _ in range(300):
        for body in (a, b):
            body.step(0.002, np.zeros(3), np.zeros(3), [0.0, 0.0, 0.0])
        met = collide(a, b) or met
        x = a.c[:, None] + a.R @ a.points
        y = b.R.T @ (x - b.c[:, None]) + b.c0[:, None]  # in the L's frame at the start
        inside = shape.inside(y)
        if inside.any():
            assert shape.nearest(y[:, inside])[1].max() < 1e-9
        assert a.mass * a.u + b.mass * b.u == pytest.approx(P0, abs=1e-12)
        e = energy(a) + energy(b)
        assert e <= E * (1 + 1e-12)
        E = e
    assert met


def _piston(lo, hi, velocity, omega=0.0, centre=None):
    """An obstacle box on a prescribed path (constant ``velocity``, turning at ``omega`` about
    ``centre``) as a floating body's contact sees it (``floating.Driven``)."""
    from wcsph.boundaries.floating import Driven
    from wcsph.boundaries.motion import Motion

    spec = {"kind": "velocity", "velocity": list(velocity), "omega": omega, "amplitude": None, "angle_amplitude": 0.0,
            "frequency": 0.0, "phase": 0.0, "centre": None, "axis": None, "file": "", "height": 0.0, "period": 0.0,
            "depth": 0.0, "ramp": -1.0}
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    c = (lo + hi) / 2 if centre is None else np.asarray(centre, dtype=float)
    grid = [np.linspace(lo[a], hi[a], 9) for a in range(2)]
    pts = np.array([p for p in np.array(np.meshgrid(*grid)).reshape(2, -1).T
                    if np.any(np.isclose(p, lo) | np.isclose(p, hi))]).T
    return Driven(Motion(spec, 2), c, pts, [box_faces(lo - c, hi - c)])


@pytest.mark.parametrize("offset", [0.0, 0.25])
def test_a_piston_on_its_path_pushes_a_floating_box_ahead_of_it(offset):
    """A paddle on a prescribed path (1 m/s along x, no gravity) meets a floating box at rest
    0.2 m ahead of it: no wall point of either is ever inside the other, the paddle keeps
    its path (an infinite mass), and, met face to face, the box leaves with the paddle's
    speed exactly without turning (a rigid, inelastic contact); met by its lower edge alone
    (the box 0.25 m higher: the paddle's top 0.05 m above its bottom, below its centre), the
    box is pushed and turned.
    Before the change the two met through the fluid alone: without fluid the paddle passed
    through the box."""
    from wcsph.boundaries.floating import collide

    paddle = _piston([0.2, 0.3], [0.4, 0.7], [1.0, 0.0])
    box, pts = _box_body([0.6, 0.4 + offset], [0.8, 0.6 + offset], 1.0)
    box.meet(pts, [])
    dt = 1e-3
    for k in range(1, 401):
        t = k * dt
        box.step(dt, [0.0, 0.0], 0.0, [0.0, 0.0])
        paddle.at(t)
        collide(box, paddle)
        assert paddle.c == pytest.approx([0.3 + t, 0.5], abs=1e-12) and paddle.theta == 0.0
        for p, q, lo, hi in ((box, paddle, [-0.1, -0.2], [0.1, 0.2]), (paddle, box, *box.box)):
            x = p.c[:, None] + _rot(p.theta) @ p.points
            y = _rot(q.theta).T @ (x - q.c[:, None])
            inside = np.all((y > np.asarray(lo)[:, None] + 1e-12) & (y < np.asarray(hi)[:, None] - 1e-12), axis=0)
            assert not inside.any(), t
    assert box.c[0] > 0.7 + 0.1  # moved on beyond where it started
    if offset == 0.0:
        assert box.u == pytest.approx([1.0, 0.0], abs=1e-12) and abs(box.omega) < 1e-12
        assert box.c[0] - 0.1 == pytest.approx(paddle.c[0] + 0.1, abs=1e-9)  # face to face
    else:
        assert box.u[0] >= 1.0 - 1e-9 and abs(box.omega) > 0.5, (box.u, box.omega)


def test_a_case_box_pushed_by_a_moving_obstacle_stays_out_of_it(tmp_path):
    """In a case: a floating box on the tank's floor (the water behind a dam at the far end)
    and an obstacle box on a prescribed path (0.5 m/s along x) that reaches it at 0.3 s.
    The box is pushed along the floor ahead of the obstacle, its face on the obstacle's
    (within 1e-9 m), at the obstacle's speed, instead of being passed through."""
    case = _free_fall_case(2)
    case["time"]["end"] = 0.6
    case["fluid"] = [{"min": [1.8, 0.0], "max": [2.0, 0.2]}]
    case["obstacle"].append({"min": [1.65, 0.0], "max": [1.75, 0.5]})  # the dam
    case["obstacle"][0].update(min=[0.6, 0.0], max=[0.8, 0.2])  # resting on the floor
    case["obstacle"].append({"name": "paddle", "min": [0.2, 0.0], "max": [0.45, 0.4],
                             "motion": {"kind": "velocity", "velocity": [0.5, 0.0]}})
    wcsph.run(case, output=tmp_path, progress=False)
    last = list(csv.DictReader(open(tmp_path / "probes.csv")))[-1]
    t = float(last["time"])
    paddle_front = 0.45 + 0.5 * t
    assert float(last["box_x"]) - 0.1 == pytest.approx(paddle_front, abs=1e-9)
    assert float(last["box_vx"]) == pytest.approx(0.5, abs=1e-9)
    assert float(last["box_y"]) == pytest.approx(0.1, abs=1e-9)


def test_a_box_pushed_by_a_moving_3d_wall_mesh_stays_out_of_it(tmp_path, box_stl):
    """The case above in 3D with the pusher a closed wall mesh on a prescribed path (a block
    read from an STL file, 0.5 m/s along x): the floating box on the floor is pushed ahead of
    it, face on face within 1e-9 m, at its speed."""
    path = box_stl("pusher.stl", [0.2, 0.3, 0.0], [0.45, 0.7, 0.4])
    case = _free_fall_case(3)
    case["time"]["end"] = 0.5
    case["fluid"] = [{"min": [1.8, 0.0, 0.0], "max": [2.0, 2.0, 0.2]}]
    case["obstacle"].append({"min": [1.65, 0.0, 0.0], "max": [1.75, 2.0, 0.5]})
    case["obstacle"][0].update(min=[0.6, 0.4, 0.0], max=[0.8, 0.6, 0.2])
    case["walls"] = [{"mesh": str(path), "motion": {"kind": "velocity", "velocity": [0.5, 0.0, 0.0]}}]
    wcsph.run(case, output=tmp_path / "out", progress=False)
    last = list(csv.DictReader(open(tmp_path / "out" / "probes.csv")))[-1]
    t = float(last["time"])
    assert float(last["box_x"]) - 0.1 == pytest.approx(0.45 + 0.5 * t, abs=1e-9)
    assert float(last["box_vx"]) == pytest.approx(0.5, abs=1e-9)
    assert float(last["box_z"]) == pytest.approx(0.1, abs=1e-9)


def test_a_box_dropped_in_a_tank_mesh_lands_on_its_floor(tmp_path, box_stl):
    """The tank as a closed wall mesh with the fluid inside (``fluid_side = "inside"``, a
    1 m cube) and a floating box dropped in it: the box stays where it was across and lands
    on the mesh's floor (at rest, its bottom on the floor within 1e-9 m). Before the change
    the mesh was taken for an obstacle the box had to leave: at the first step the box was
    thrown 0.6 m sideways, out of the tank through its wall."""
    case = _free_fall_case(3)
    case.pop("tank")
    case["domain"] = {"min": [-0.2] * 3, "max": [1.2] * 3}
    case["walls"] = [{"mesh": box_stl("tank.stl", [0.0] * 3, [1.0] * 3), "fluid_side": "inside"}]
    case["fluid"] = [{"min": [0.85, 0.0, 0.0], "max": [1.0, 1.0, 0.1]}]
    case["obstacle"].append({"min": [0.75, 0.0, 0.0], "max": [0.8, 1.0, 0.3]})  # a dam: no water under the box
    case["obstacle"][0].update(min=[0.4, 0.4, 0.5], max=[0.6, 0.6, 0.7])
    case["time"]["end"] = 0.5
    wcsph.run(case, output=tmp_path / "out", progress=False)
    last = list(csv.DictReader(open(tmp_path / "out" / "probes.csv")))[-1]
    assert float(last["box_x"]) == pytest.approx(0.5, abs=1e-9) and float(last["box_y"]) == pytest.approx(0.5, abs=1e-9)
    assert float(last["box_z"]) - 0.1 == pytest.approx(0.0, abs=1e-9)
    assert abs(float(last["box_vz"])) < 1e-12


def test_a_moving_tank_pushes_the_box_inside_it(tmp_path):
    """The tank on a prescribed path (0.5 m/s along x, 2D) with a floating box resting on its
    frictionless floor 0.2 m from its left wall: from 0.4 s the wall pushes the box ahead of
    it, face on face within 1e-9 m, at the tank's speed. Before the change the box was held
    inside the tank's faces at rest, and the moving wall passed through it."""
    case = _free_fall_case(2)
    case["domain"] = {"min": [-0.1, -0.1], "max": [3.0, 2.1]}
    case["tank"]["motion"] = {"kind": "velocity", "velocity": [0.5, 0.0]}
    case["fluid"] = [{"min": [1.8, 0.0], "max": [2.0, 0.2]}]
    case["obstacle"].append({"min": [1.65, 0.0], "max": [1.75, 0.5], "motion": {"kind": "velocity", "velocity": [0.5, 0.0]}})
    case["obstacle"][0].update(min=[0.2, 0.0], max=[0.4, 0.2])
    case["time"]["end"] = 0.6
    wcsph.run(case, output=tmp_path, progress=False)
    last = list(csv.DictReader(open(tmp_path / "probes.csv")))[-1]
    t = float(last["time"])
    assert float(last["box_x"]) - 0.1 == pytest.approx(0.5 * t, abs=1e-9)
    assert float(last["box_vx"]) == pytest.approx(0.5, abs=1e-9)
    assert float(last["box_y"]) == pytest.approx(0.1, abs=1e-9)


@pytest.mark.parametrize("where,ok", [("through the tank's wall", False), ("in the other box", False),
                                      ("in a fixed block", False), ("on the other box, face on face", True)])
def test_a_body_that_starts_inside_a_wall_or_a_body_is_a_case_error(where, ok, tmp_path):
    """A floating box placed through the tank's wall, overlapping another floating box or
    inside a fixed obstacle is one line naming it: the contacts would have pushed it out at
    its first step, a jump the case did not ask for (before, it ran so). Face on face with
    another body it is placed clear, and runs."""
    case = _free_fall_case(2)
    case["time"]["end"] = 0.002
    other = {"name": "top", "min": [1.4, 1.4], "max": [1.6, 1.6], "floating": {"density": 500.0}}
    if where == "through the tank's wall":
        case["obstacle"][0].update(min=[1.9, 1.2], max=[2.1, 1.4])
    elif where == "in the other box":
        case["obstacle"].append(dict(other, min=[1.45, 1.35], max=[1.65, 1.55]))
    elif where == "in a fixed block":
        case["obstacle"].append({"min": [1.3, 1.3], "max": [1.7, 1.35]})
    else:
        case["obstacle"].append(other)
    if ok:
        wcsph.run(case, output=tmp_path, progress=False)
        return
    with pytest.raises(CaseError, match=r"obstacle\[\d\]: the floating body starts inside a wall or another body"):
        wcsph.run(case, output=tmp_path, progress=False)


@pytest.mark.parametrize("shape", ["convex", "concave"])
def test_a_box_dropped_in_a_container_polygon_lands_on_its_floor(shape, tmp_path):
    """The tank as a closed polygon running counter-clockwise (the fluid inside), with no
    tank box: a convex one (held by its faces) and a concave one, a floor with a step in it
    (held by its wall points). The box dropped in it lands on its floor (its bottom on the
    floor within 1e-9 m, at rest, where it was across), and the water stays in the polygon.
    Before the change a closed polygon was always a body: the box was thrown out of the
    tank at the first step and the water was carved from outside it."""
    pts = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]]
    if shape == "concave":
        pts = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.3], [2.0, 0.3], [2.0, 2.0], [0.0, 2.0]]
    case = _free_fall_case(2)
    case.pop("tank")
    case["domain"] = {"min": [-0.2, -0.2], "max": [2.2, 2.2]}
    case["polygon"] = [{"points": pts, "closed": True}]
    case["fluid"] = [{"min": [-0.1, -0.1], "max": [0.3, 0.2]}]  # reaches out of the polygon
    case["obstacle"].append({"min": [0.35, 0.0], "max": [0.45, 0.5]})  # a dam: no water under the box
    case["time"]["end"] = 0.7
    s = wcsph.run(case, output=tmp_path / "out", progress=False)
    last = list(csv.DictReader(open(tmp_path / "out" / "probes.csv")))[-1]
    floor = 0.3 if shape == "concave" else 0.0
    assert float(last["box_x"]) == pytest.approx(1.5, abs=1e-9)
    assert float(last["box_y"]) - 0.1 - floor == pytest.approx(0.0, abs=1e-9)
    assert abs(float(last["box_vy"])) < 1e-12
    assert s["n_fluid"] == 6 * 4 and s["dropped"] == 0


@pytest.mark.parametrize("source", ["file", "polyline"])
def test_a_box_dropped_on_a_wall_of_points_rests_on_it(source, tmp_path):
    """A shelf at y = 0.6 m across 0.3-0.7 m, as a wall particle file or an open polygon,
    under the dropped box: the box rests on the shelf's points (its bottom on them within
    1e-9 m, at rest) instead of falling through to the floor. A wall with no shape meets a
    body by its points, which the body's faces hold out."""
    import meshio

    xs = 0.3 + 0.05 * np.arange(9)
    if source == "file":
        pts = np.column_stack([xs, np.full(9, 0.6), np.zeros(9)])
        meshio.write(tmp_path / "shelf.vtk", meshio.Mesh(pts, [("vertex", np.arange(9)[:, None])], point_data={
            "normals": np.tile([0.0, 1.0, 0.0], (9, 1)), "elementSize": np.full(9, 0.05)}))
        extra = {"walls": [{"file": str(tmp_path / "shelf.vtk")}]}
    else:
        extra = {"polygon": [{"points": [[0.7, 0.6], [0.3, 0.6]]}]}
    case = _free_fall_case(2)
    case["time"]["end"] = 0.7
    case["fluid"] = [{"min": [1.8, 0.0], "max": [2.0, 0.2]}]
    case["obstacle"].append({"min": [1.65, 0.0], "max": [1.75, 0.5]})
    case["obstacle"][0].update(min=[0.4, 1.2], max=[0.6, 1.4])
    case.update(extra)
    wcsph.run(case, output=tmp_path / "out", progress=False)
    last = list(csv.DictReader(open(tmp_path / "out" / "probes.csv")))[-1]
    assert float(last["box_y"]) - 0.1 - 0.6 == pytest.approx(0.0, abs=1e-9)
    assert abs(float(last["box_vy"])) < 1e-12 and float(last["box_x"]) == pytest.approx(0.5, abs=1e-9)
