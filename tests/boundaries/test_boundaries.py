"""Periodic boundaries, moving walls and initial fields, against exact solutions."""
import math
import subprocess
import sys

import numpy as np
import pytest

import wcsph
from wcsph.case.config import load, validate
from wcsph.errors import CaseError
from wcsph.boundaries.motion import Bodies
from wcsph.validation import references as ref
from wcsph.validation import couette, poiseuille, _tg_rate


def _advance(sim, t):
    while sim.t < t - 1e-12:
        sim.step(min(sim.time_step(), t - sim.t))


# ------------------------------------------------------------------ periodic
def test_periodic_seam_is_invisible_and_momentum_is_conserved():
    """A doubly periodic box of fluid: at rest, every particle has the same density and no
    acceleration (a particle at the seam sees the same neighbours as one in the middle); with
    a random velocity field and viscosity, total momentum stays what it was to round-off,
    and particles that leave through one side come back at the other."""
    case = load("taylor_green_2d", [("dp", 0.04), ("fluid", [{"min": [0.0, 0.0], "max": [1.0, 1.0]}])])
    sim = wcsph.Simulation(case)
    sim.evaluate(sim.params_for(1e-4))
    rho, a = sim.host(sim.fluid, "rho", "dvdt")
    assert sim.fluid.n == 625
    assert np.abs(a).max() < 1e-9
    rng = np.random.default_rng(1)
    v = rng.normal(0.0, 0.5, (2, sim.fluid.n))
    v -= v.mean(axis=1, keepdims=True)
    v[0] += 0.7  # a net flow through the seam
    sim.fluid["v"] = v.copy()
    m = sim.host(sim.fluid, "m")[0]
    p0 = (m * v).sum(axis=1)
    _advance(sim, 0.3)
    x, v1 = sim.host(sim.fluid, "x", "v")
    assert sim.fluid.n == 625 and sim.dropped == 0
    assert np.all((x >= 0) & (x < 1))
    assert np.abs((m * v1).sum(axis=1) - p0).max() < 1e-9 * np.abs(m * v).sum()


@pytest.mark.parametrize("model", ["bi", pytest.param("classic", marks=pytest.mark.validation)])
def test_periodic_poiseuille_matches_the_series_solution(model):
    """40 particles across, periodic along the flow: the L2 velocity error at t = 0.1, 0.3
    and 1 s (steady) is below 1 % of u_max (measured 0.13 % WCSPH-BI, 0.29 % classic with
    Adami's no-slip wall velocity; 7.5 % classic without it: the no-slip then sits at the
    wall particles' depth)."""
    from wcsph.validation import CLASSIC

    r = poiseuille(False, CLASSIC if model == "classic" else ())
    assert r.passed and r.measured < 0.01, r.detail


@pytest.mark.parametrize("model", ["bi", pytest.param("classic", marks=pytest.mark.validation)])
def test_couette_with_a_moving_plate_and_its_shear_force(model):
    """The upper plate moves at U0: the transient profile within 1 % at t = 0.05, 0.2, 1 s
    (measured 0.04 % in both models); at steady state the shear force on each plate
    is mu U0 / L times its length, within 1 % (measured 0.1 % and 0.4 %), opposite on the two."""
    from wcsph.validation import CLASSIC

    over = CLASSIC if model == "classic" else []
    r = couette(False, over)
    assert r.passed, r.detail
    sim = wcsph.Simulation(load("couette_2d", over))
    _advance(sim, 1.0)
    loads = sim.body_loads()
    tau = 1e-3 * 2.5e-5 / 1e-3
    assert loads["bottom_fx"] == pytest.approx(tau * 5e-4, rel=0.01)
    assert loads["top_fx"] == pytest.approx(-tau * 5e-4, rel=0.01)
    assert abs(loads["bottom_fy"]) < 1e-3 * loads["bottom_fx"]
    x = sim.host(sim.walls, "x")[0]
    assert np.all((x[0] >= 0) & (x[0] < 5e-4))  # the moving plate wraps round the seam


def test_wall_shear_of_a_starting_plate_in_the_consistent_scheme():
    """Couette flow's start (Stokes' first problem while the boundary layer is thin) with the
    consistent BI scheme: the moving plate's shear load against the exact series
    mu U/L (1 + 2 sum_n exp(-n^2 pi^2 nu t / L^2)), within 2.5 % once the layer sqrt(nu t) is
    1.4 h thick and 1 % at steady state (measured -1.3 % and -0.1 %; with the fluid's
    Shepard-divided share as the load it read +31 % and +33 %)."""
    sim = wcsph.Simulation(load("couette_2d", [("model.BCType", "BIConsistent_numeric")]))
    for t, tol in ((0.005, 0.025), (0.02, 0.01), (1.0, 0.01)):
        _advance(sim, t)
        exact = ref.couette_wall_shear(t, L=1e-3, U=2.5e-5, mu=1e-3, nu=1e-6) * 5e-4  # times the plate's length
        assert -sim.body_loads()["top_fx"] == pytest.approx(exact, rel=tol), t


@pytest.mark.validation
def test_open_channel_keeps_the_poiseuille_profile(tmp_path):
    """Inflow with the parabola, outflow at p = 0: after two transits of the channel the
    downstream profile is the parabola within 2 % (measured 0.3-0.5 %), the pressure drop is
    8 mu u_max L / H^2 within 5 %, particles are created and removed in equal numbers (within
    a layer), and run.json counts them."""
    from wcsph.validation import poiseuille_open

    r = poiseuille_open(False)
    assert r.passed, r.detail
    over = [("time.end", 0.3), ("output.vtk", False)]
    n0 = wcsph.Simulation(load("poiseuille_open_2d", over)).fluid.n
    s = wcsph.run("poiseuille_open_2d", output=tmp_path, progress=False, overrides=over)
    ob = s["open_boundary"]
    assert ob["created"] > 100 and abs(ob["created"] - ob["removed"]) <= 40
    assert s["n_fluid"] == n0 + ob["created"] - ob["removed"]


def test_open_channel_coarse(tmp_path):
    """32 particles across, buffers one kernel support deep (the 40-across check over two
    transits is in the validation set): the downstream profile over one transit within 2 %
    of the inflow parabola (measured 0.4 %), particles created and removed in equal numbers
    within a layer, and run.json counts them."""
    from wcsph.validation import poiseuille_open

    r = poiseuille_open(False, [("dp", 0.03125)], times=(1.0, 2.0))
    assert r.measured < 0.02, r.detail
    over = [("time.end", 0.3), ("output.vtk", False), ("dp", 0.03125)]
    n0 = wcsph.Simulation(load("poiseuille_open_2d", over)).fluid.n
    s = wcsph.run("poiseuille_open_2d", output=tmp_path, progress=False, overrides=over)
    ob = s["open_boundary"]
    assert ob["created"] > 50 and abs(ob["created"] - ob["removed"]) <= 20
    assert s["n_fluid"] == n0 + ob["created"] - ob["removed"]


def test_an_inlet_particle_takes_the_mass_of_the_one_it_replaces():
    """A buffer particle created at the inlet's far side takes the mass of the one that left
    the buffer for the fluid (a fitted box's cell or a classic continuity start gives each
    its own), not the case's particle mass: the inlet's buffer marked with 1.01 times it,
    every particle created over 0.3 s carries the mark."""
    over = [("time.end", 0.3), ("output.vtk", False), ("dp", 0.03125)]
    sim = wcsph.Simulation(load("poiseuille_open_2d", over))
    m, kind, ids = sim.host(sim.fluid, "m", "kind", "id")
    n0 = int(ids.max()) + 1
    inlet = [k + 1 for k, ob in enumerate(sim.case["open_boundary"]) if ob["kind"] == "inlet"]
    m = np.where(np.isin(kind, inlet), 1.01 * m, m)
    sim.fluid["m"] = sim.state.backend.to_device(m.astype(sim.fluid["m"].dtype))
    sim.run(progress=False)
    m, ids = sim.host(sim.fluid, "m", "id")
    new = ids >= n0
    assert new.sum() > 50
    assert np.allclose(m[new], 1.01 * sim.state.mass, rtol=1e-6), np.unique(m[new])


def test_open_boundary_case_errors():
    base = dict(BASE, domain={"min": [-0.5, -0.5], "max": [1.5, 1.5]})
    bad = [({"kind": "inlet", "min": [-0.2, 0.0], "max": [0.0, 0.5], "normal": [1.0, 0.0]}, r"open_boundary\[0\]\.velocity"),
           ({"kind": "inlet", "min": [-0.2, 0.0], "max": [0.0, 0.5], "normal": [1.0, 1.0], "velocity": [1.0, 0.0]},
            r"open_boundary\[0\]\.normal"),
           ({"kind": "outlet", "min": [1.0, 0.0], "max": [1.05, 0.5], "normal": [-1.0, 0.0]}, r"open_boundary\[0\]\.max"),
           ({"kind": "sideways", "min": [1.0, 0.0], "max": [1.2, 0.5], "normal": [-1.0, 0.0]}, r"open_boundary\[0\]\.kind")]
    for ob, key in bad:
        with pytest.raises(CaseError, match=key):
            validate(dict(base, open_boundary=[ob]))
    thin = validate(dict(base, open_boundary=[{"kind": "outlet", "min": [1.0, 0.0], "max": [1.2, 0.5],
                                               "normal": [-1.0, 0.0]}]))
    assert any("less than the kernel support" in w for w in thin["_warnings"])
    with pytest.raises(CaseError, match="domain: open boundaries need the domain box"):
        validate(dict(BASE, open_boundary=[bad[0][0] | {"velocity": [1.0, 0.0]}]))


def test_taylor_green_decay_rate_coarse():
    """50 x 50 particles (the 100 x 100 check, within 2 %, is in the validation set): the
    decay rate of the kinetic energy within 3.5 % of -16 pi^2 / Re (measured 2.5 %)."""
    rate, ts, ks = _tg_rate(0.02)
    assert rate == pytest.approx(ref.taylor_green_decay_rate(100.0), rel=0.035)


@pytest.mark.validation
def test_taylor_green_decay_rate():
    rate, ts, ks = _tg_rate(0.01)
    assert rate == pytest.approx(ref.taylor_green_decay_rate(100.0), rel=0.02)


@pytest.mark.validation
def test_full_validation_set(tmp_path):
    from wcsph.validation import OPEN_GOALS, run_all

    results = run_all(tmp_path, quick=False, log=lambda s: None)
    assert (tmp_path / "report.md").exists()
    # every check passes but the open goals, which fail (one that passes leaves OPEN_GOALS)
    assert {r.check for r in results if not r.passed} == OPEN_GOALS, [(r.name, r.measured) for r in results]


def test_validate_command_writes_a_report(tmp_path):
    out = tmp_path / "report"
    r = subprocess.run([sys.executable, "-m", "wcsph.cli", "validate", "--only", "couette", "-o", str(out)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    text = (out / "report.md").read_text()
    assert "| Couette, moving wall, WCSPH-BI |" in text and "pass" in text
    assert "Couette, moving wall, classic" not in text  # the check named couette alone, not couette_classic
    assert (out / "check_00.png").stat().st_size > 1000
    r = subprocess.run([sys.executable, "-m", "wcsph.cli", "validate", "--only", "nosuch", "-o", str(out)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 2 and "no check's name contains it" in r.stderr and "Traceback" not in r.stderr


# ------------------------------------------------------------------ moving walls
MOTION_SPEC = {"velocity": None, "omega": 0.0, "amplitude": None, "angle_amplitude": 0.0, "frequency": 0.0,
               "phase": 0.0, "centre": None, "axis": None, "file": "", "height": 0.0, "period": 0.0, "depth": 0.0,
               "ramp": -1.0}


@pytest.mark.parametrize("dim, motion", [
    (2, {"kind": "velocity", "velocity": [0.3, -0.1], "omega": 2.0}),
    (2, {"kind": "sinusoidal", "amplitude": [0.05, 0.02], "angle_amplitude": 0.3, "frequency": 1.5, "phase": 0.2}),
    (2, {"kind": "sinusoidal", "amplitude": [0.05, 0.02], "angle_amplitude": 0.3, "frequency": 1.5, "phase": 0.2,
         "ramp": 0.9}),  # t = 0.37: in the ramp
    (3, {"kind": "velocity", "velocity": [0.3, -0.1, 0.2], "omega": 2.0, "axis": [1.0, 2.0, 2.0]}),
    (3, {"kind": "sinusoidal", "amplitude": [0.05, 0.02, 0.01], "angle_amplitude": 0.3, "frequency": 1.5,
         "phase": 0.2, "axis": [0.0, 1.0, 1.0]}),
    (2, {"kind": "piston", "height": 0.06, "period": 1.2, "depth": 0.4, "ramp": 0.8}),  # t = 0.37: in the ramp
    (2, {"kind": "flap", "height": 0.06, "period": 0.5, "depth": 0.4, "ramp": 0.0, "centre": [0.0, -0.4]}),
    (3, {"kind": "flap", "height": 0.06, "period": 1.2, "depth": 0.4, "centre": [0.0, 0.0, -0.4],
         "axis": [0.0, 1.0, 0.0]}),
])
def test_wall_velocity_and_acceleration_are_the_rates_of_its_position(dim, motion):
    """v_b and a_b of every wall point are the first and second time derivatives of its
    position (central differences; the centripetal part included), normals turn with the
    body, and ``Bodies.bounds`` holds the points wherever the motion takes them."""
    spec = dict(MOTION_SPEC, **motion)
    if dim == 2:
        x0 = np.array([[0.0, 0.1, 0.1, 0.0], [0.0, 0.0, 0.1, 0.1]])
        n0 = np.array([[0.0, 1.0, 0.0, -1.0], [-1.0, 0.0, 1.0, 0.0]])
    else:
        x0 = np.array([[0.0, 0.1, 0.1, 0.0], [0.0, 0.0, 0.1, 0.1], [0.0, 0.05, -0.1, 0.2]])
        n0 = np.array([[0.0, 1.0, 0.0, -1.0], [-1.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    body = np.zeros(4, dtype=np.int64)
    b = Bodies([("square", spec, "obstacle[0]")], dim, x0, n0, body)
    t, h = 0.37, 1e-4
    xa, _, va, _ = b.place(t - h, x0, n0, body)
    xb, _, vb, _ = b.place(t + h, x0, n0, body)
    x, n, v, a = b.place(t, x0, n0, body)
    assert np.allclose(v, (xb - xa) / (2 * h), atol=1e-6)
    assert np.allclose(a, (xb - 2 * x + xa) / h**2, atol=1e-5)
    assert np.allclose(a, (vb - va) / (2 * h), atol=1e-6)
    assert np.allclose(np.linalg.norm(n, axis=0), 1)
    edge = x[:, 1] - x[:, 0]  # the bottom edge; its normal stays perpendicular to it
    assert abs(edge @ n[:, 0]) < 1e-12
    # the box ``bounds`` gives without placing the points holds them (what lets a GPU sort
    # the moving walls without reading their count back), and is not loose by more than
    # the body's turned box
    for tt in np.linspace(0.0, 2.0, 21):
        x, *_ = b.place(tt, x0, n0, body)
        lo, hi = b.bounds(b.poses(tt))
        assert np.all(x >= lo[:, None] - 1e-12) and np.all(x <= hi[:, None] + 1e-12)
        assert np.all(hi - lo <= np.sqrt(dim) * (x0.max(axis=1) - x0.min(axis=1)).max() + 1e-12)


def test_wavemaker_strokes_follow_linear_theory():
    """k solves the dispersion relation; Biesel's ratio H/S tends to kh (piston) and kh/2
    (flap) in shallow water and to 2 in deep water; the flume case's piston stroke."""
    from wcsph.boundaries.motion import wave_number, wavemaker_stroke

    for T, h in ((1.2, 0.4), (5.0, 0.2), (0.6, 3.0)):
        w = 2 * math.pi / T
        k = wave_number(w, h, 9.81)
        assert 9.81 * k * math.tanh(k * h) == pytest.approx(w * w, rel=1e-12)
    S, k = wavemaker_stroke("piston", 0.01, 20.0, 0.1, 9.81)  # kh = 0.05
    assert 0.01 / S == pytest.approx(k * 0.1, rel=1e-3)
    S, k = wavemaker_stroke("flap", 0.01, 20.0, 0.1, 9.81)
    assert 0.01 / S == pytest.approx(k * 0.1 / 2, rel=1e-3)
    for kind in ("piston", "flap"):
        S, k = wavemaker_stroke(kind, 0.1, 0.8, 10.0, 9.81)  # kh = 63
        assert 0.1 / S == pytest.approx(2.0, rel=0.04)
    assert wavemaker_stroke("piston", 0.06, 1.2, 0.4, 9.81)[0] == pytest.approx(0.0484, abs=1e-4)


def test_damping_zone_relaxes_the_velocity_inside_it():
    """v <- v (1 - dt beta s^2), s the depth into the zone along its direction over its length:
    nothing before and at its entrance, the full rate at its end."""
    from wcsph.backends import get_backend
    from wcsph.solver.damping import Damping, DampedFluid

    zone = {"min": [1.0, 0.0], "max": [3.0, 1.0], "direction": [1.0, 0.0], "strength": 10.0}
    d = Damping(get_backend("cpu"), 2, [zone])
    x = np.array([[0.5, 1.0, 2.0, 2.999], [0.5, 0.5, 0.5, 0.5]])
    v = np.ones((2, 4))

    class S:  # the state the stage reads
        fluid = type("F", (), {"n": 4, "__getitem__": lambda self, k: {"x": x, "v": v}[k]})()
        dtype = np.float64
        dt = 0.01

    d(S)
    s = np.array([0.0, 0.0, 0.5, 0.9995])
    assert np.allclose(v, 1 - 0.01 * 10.0 * s**2)
    assert DampedFluid._fields == ("x", "v")


def test_table_motion_from_csv(tmp_path):
    (tmp_path / "m.csv").write_text("t,x,y,theta\n0,0,0,0\n1,0.2,0,0.1\n2,0.2,0.1,0.1\n")
    spec = dict(MOTION_SPEC, kind="table", file="m.csv", centre=[0.0, 0.0])
    x0 = np.array([[1.0], [0.0]])
    one = np.zeros(1, dtype=np.int64)
    b = Bodies([("flap", spec, "obstacle[0]")], 2, x0, None, one, tmp_path)
    x, n, v, a = b.place(0.5, x0, None, one)
    c, s = math.cos(0.05), math.sin(0.05)
    assert np.allclose(x[:, 0], [0.1 + c, s])
    assert n is None and np.allclose(v[:, 0], [0.2 - 0.1 * s, 0.1 * c])  # d' + omega x r
    # the rates at the midpoints 0.5 and 1.5 are (0.2, 0, 0.1) and (0, 0.1, 0): their slope is
    # the acceleration between them, plus the centripetal -omega^2 r (omega 0.1 in the first row)
    x, _, v, a = b.place(0.9, x0, None, one)
    r = x[:, 0] - [0.18, 0.0]
    alpha, omega = -0.1, 0.1
    assert np.allclose(a[:, 0], np.array([-0.2, 0.1]) + alpha * np.array([-r[1], r[0]]) - omega**2 * r)
    x, _, _, a = b.place(0.25, x0, None, one)  # before the first midpoint: the centripetal part only
    assert np.allclose(a[:, 0], -0.1**2 * (x[:, 0] - [0.05, 0.0]))


# ------------------------------------------------------------------ case errors
BASE = {"dim": 2, "dp": 0.1, "time": {"end": 0.1}, "fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.5]}],
        "tank": {"min": [0.0, 0.0], "max": [1.0, 1.0]}}


@pytest.mark.parametrize("change, key", [
    ({"domain": {"periodic": [True, False]}, "tank": {"min": [0.0, 0.0], "max": [1.05, 1.0]}}, "domain.periodic"),
    ({"domain": {"periodic": [True, False]}, "tank": None}, "domain.periodic"),
    ({"domain": {"periodic": [True]}}, "domain.periodic"),
    ({"fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.5], "velocity": ["import os", 0.0]}]}, "fluid[0].velocity[0]"),
    ({"fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.5], "pressure": "__class__"}]}, "fluid[0].pressure"),
    ({"obstacle": [{"min": [0.3, 0.6], "max": [0.5, 0.8], "motion": {"kind": "spin"}}]}, "obstacle[0].motion.kind"),
    ({"obstacle": [{"min": [0.3, 0.6], "max": [0.5, 0.8], "name": "a b"}]}, "obstacle[0].name"),
])
def test_boundary_case_errors_name_the_key(change, key):
    data = dict(BASE, **change)
    if data.get("tank") is None:
        data.pop("tank")
    with pytest.raises(CaseError, match=key.replace("[", r"\[").replace("]", r"\]")):
        validate(data)


def test_periodic_box_too_short_for_the_kernel():
    data = dict(BASE, dp=0.1, tank={"min": [0.0, 0.0], "max": [0.4, 1.0]},
                fluid=[{"min": [0.0, 0.0], "max": [0.4, 0.5]}], domain={"periodic": [True, False]})
    with pytest.raises(CaseError, match="domain.periodic: the periodic length"):
        wcsph.Simulation(validate(data))


# ------------------------------------------------------------------ geometry from files
def _cube(lo, hi):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = lo + np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float) * (hi - lo)
    q = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return v, np.array([[a, b, c] for a, b, c, d in q] + [[a, c, d] for a, b, c, d in q])


def _stl(path, v, t):
    import meshio

    meshio.write(path, meshio.Mesh(v, [("triangle", t)]))
    return str(path)


def test_surface_mesh_becomes_boundary_elements(tmp_path):
    """A box tank from STL: element areas add up to its surface, normals point out of the
    fluid (down on the floor), whatever the file's orientation."""
    from wcsph.io import readers

    v, t = _cube([0, 0, 0], [0.4, 0.3, 0.3])
    for tris in (t, t[:, ::-1]):  # outward or inward in the file
        verts, faces = readers.read_surface(_stl(tmp_path / "tank.stl", v, tris), 3)
        x, n, s = readers.face_elements(verts, faces, 0.02, fluid_inside=True)
        assert s.sum() == pytest.approx(2 * (0.12 + 0.12 + 0.09))
        assert np.allclose(n[:, x[2] == 0].T, [0, 0, -1])
        assert np.allclose(n[:, np.isclose(x[0], 0.4)].T, [1, 0, 0])
        assert 0.66 / 0.02**2 < x.shape[1] < 3 * 0.66 / 0.02**2  # about two triangles per dp^2


def test_open_or_inconsistent_meshes_are_case_errors(tmp_path):
    v, t = _cube([0, 0, 0], [1, 1, 1])
    flipped = t.copy()
    flipped[3] = flipped[3, ::-1]
    base = {"dim": 3, "dp": 0.1, "time": {"end": 0.1}, "fluid": [{"min": [0.2, 0.2, 0.2], "max": [0.8, 0.8, 0.6]}],
            "model": {"name": "bi"}}
    for tris, message in ((t[1:], "not closed"), (flipped, "inconsistent normals")):
        path = _stl(tmp_path / "bad.stl", v, tris)
        case = validate(dict(base, walls=[{"mesh": path, "fluid_side": "inside"}]))
        with pytest.raises(CaseError, match=r"walls\[0\]\.mesh: .*bad.stl: .*" + message):
            wcsph.Simulation(case)


@pytest.mark.parametrize("model", ["bi", pytest.param("classic", marks=pytest.mark.validation)])
def test_fluid_filling_a_closed_surface_in_an_stl_tank(model, tmp_path):
    """A 3D tank and the water in it, both from STL: the fill gives the lattice of the box
    (10 x 15 x 7), the walls are elements (WCSPH-BI) or sampled particles (classic), and a
    short run keeps every particle."""
    tank = _stl(tmp_path / "tank.stl", *_cube([0, 0, 0], [0.4, 0.3, 0.3]))
    water = _stl(tmp_path / "water.stl", *_cube([0, 0, 0], [0.2, 0.3, 0.14]))
    from wcsph.case.config import read_toml, resolve

    shipped = read_toml(resolve("dam_break_3d" if model == "classic" else "dam_break_3d_bi"))
    case = validate({"dim": 3, "dp": 0.02, "fluid": [{"surface": water}],
                     "walls": [{"mesh": tank, "fluid_side": "inside"}], "time": {"end": 0.05},
                     "model": shipped["model"], "parameters": shipped.get("parameters", {}),
                     "physics": shipped.get("physics", {}), "output": {"progress": False}})
    sim = wcsph.Simulation(case)
    assert sim.fluid.n == 10 * 15 * 7
    s = sim.run()
    assert s["status"] == "completed" and s["dropped"] == 0
    x = sim.host(sim.fluid, "x")[0]
    # the classic walls let the bottom layer sink 0.1 dp into the floor under the start's
    # impact, as with the same tank made as a box
    assert x.min() > (0 if model == "bi" else -0.25 * 0.02) and x[0].max() < 0.4 and x[1].max() < 0.3


def test_points_from_csv_and_vtk(tmp_path):
    """Fluid from a CSV point file (with velocities) and boundary elements from a VTK point
    set with normals and sizes, as TNL-SPH's generators write them."""
    import meshio

    xs, ys = np.meshgrid(0.05 + 0.1 * np.arange(5), 0.05 + 0.1 * np.arange(3), indexing="ij")
    rows = np.column_stack([xs.ravel(), ys.ravel(), np.full(15, 0.5), np.zeros(15)])
    np.savetxt(tmp_path / "fluid.csv", rows, delimiter=",", header="x,y,vx,vy", comments="")
    floor = np.column_stack([0.05 + 0.1 * np.arange(10), np.zeros(10), np.zeros(10)])
    meshio.write(tmp_path / "floor.vtk", meshio.Mesh(floor, [("vertex", np.arange(10)[:, None])], point_data={
        "normals": np.tile([0.0, -1.0, 0.0], (10, 1)), "elementSize": np.full(10, 0.1)}))
    (tmp_path / "case.toml").write_text(
        'dim = 2\ndp = 0.1\n[[fluid]]\nfile = "fluid.csv"\n[[walls]]\nfile = "floor.vtk"\nname = "floor"\n'
        '[domain]\nmin = [0.0, -0.5]\nmax = [1.0, 1.0]\n[model]\nname = "bi"\n[time]\nend = 0.01\n')
    sim = wcsph.Simulation(load(str(tmp_path / "case.toml")))
    assert sim.fluid.n == 15 and sim.walls.n == 10
    assert np.allclose(sim.host(sim.fluid, "v")[0][0], 0.5)
    assert np.allclose(sim.host(sim.walls, "n")[0][1], -1.0)
    (tmp_path / "case2.toml").write_text((tmp_path / "case.toml").read_text().replace("floor.vtk", "fluid.csv"))
    with pytest.raises(CaseError, match=r"walls\[0\]\.file: boundary elements need the point fields n and elementSize"):
        wcsph.Simulation(load(str(tmp_path / "case2.toml")))


@pytest.mark.validation
def test_periodic_poiseuille_in_3d():
    """The channel in 3D, periodic along x and y, plates at z = 0 and z = L (WCSPH-BI, 10
    particles across: the coarsest the kernel allows in a 1 mm periodic box): the steady
    profile within 3 % of u_max (measured 2.2 %; 2D at the same resolution: 2.3 %), no cross flow,
    no particle lost."""
    L, F, nu = 1e-3, 2e-4, 1e-6
    case = validate({
        "dim": 3, "dp": 1e-4, "precision": "float64",
        "fluid": [{"min": [0, 0, 0], "max": [L, L, L]}], "tank": {"min": [0, 0, 0], "max": [L, L, L], "open_top": False},
        "domain": {"periodic": [True, True, False]},
        "model": {"name": "bi", "ViscousTerm": "PhysicalViscosity_MVT", "BCType": "BIConservative_numeric"},
        "parameters": {"rho0": 1000.0, "speedOfSound": 2.5e-4, "dynamicViscosity": 1e-3, "delta": 0.1,
                       "gravity": [F, 0.0, 0.0]},
        "time": {"end": 1.0}, "output": {"progress": False}})
    sim = wcsph.Simulation(case)
    assert sim.fluid.n == 1000 and sim.walls.n == 200
    _advance(sim, 1.0)
    x, v = sim.host(sim.fluid, "x", "v")
    err = np.sqrt(np.mean((v[0] - ref.poiseuille(x[2], sim.t, L, F, nu)) ** 2)) / (F * L**2 / (8 * nu))
    assert err < 0.03
    assert np.abs(v[1:]).max() < 1e-3 * np.abs(v[0]).max()
    assert sim.dropped == 0 and np.all((x[:2] >= 0) & (x[:2] < L))


def test_moving_square_is_pushed_back_by_the_fluid(tmp_path):
    """The square of ``moving_square_2d`` driven by its motion table (coarse, 0.5 s, no
    shifting: the loops of the open channel): its walls are where the table puts them, move
    at the table's rate, and the fluid's force on it opposes the acceleration (drag along -x,
    the side force below 5 % of it); probes.csv has its columns."""
    over = [("dp", 0.1), ("model.shifting", "None"), ("time.end", 0.5), ("output.vtk", False),
            ("output.probe_interval", 0.1)]
    sim = wcsph.Simulation(load("moving_square_2d", over))
    s = sim.run(output=tmp_path, progress=False)
    assert s["status"] == "completed" and s["dropped"] == 0
    x, v, body = sim.host(sim.walls, "x", "v", "body")
    sq = body == 1
    t = sim.t  # the first step at or past the end time
    shift = t / 2 - np.sin(np.pi * t) / (2 * np.pi)  # x(t) = U (t/2 - sin(pi t)/(2 pi)), U = 1
    assert x[0][sq].min() == pytest.approx(1.0 + shift, abs=1e-4)
    assert np.allclose(v[0][sq], (1 - np.cos(np.pi * t)) / 2, atol=0.02) and np.allclose(v[1][sq], 0.0)
    import csv

    rows = list(csv.DictReader(open(tmp_path / "probes.csv")))
    fx = np.array([float(r["square_fx"]) for r in rows[1:]])
    fy = np.array([float(r["square_fy"]) for r in rows[1:]])
    assert np.all(fx < 0) and np.all(np.abs(fy) < 0.05 * np.abs(fx))


def test_a_moving_body_load_does_not_depend_on_how_a_step_is_split():
    """Each evaluation sees a wall on a prescribed path where it is at that evaluation's time,
    and the after-step corrections where it is at the step's end: the square of
    ``moving_square_2d`` (10 across) after one step of dt, or of 0.1 dt and 0.9 dt from
    t = 1.2 s, then 20 steps more, feels the same force to 1e-3 (measured 5e-6 with the plain
    loops of a one-thread process, the suite's, and 1.2e-5 with the parallel ones; with the
    walls held at the step's start through the step and its corrections the split set the
    drag ringing, 15 % off after 20 steps from 1.2 s). From t = 0.5 s, where the square still
    accelerates, the parallel loops read 3e-5 and the plain ones 2.9e-3: a fluid particle just
    in front of the square's face is bounced (the elastic bounce's threshold) after one of the
    two splits and not after the other, its velocity 0.05 m/s apart, while the split's own
    effect on every other particle is 5e-6 m/s; a test of the walls' timing should not hang
    on that particle's round-off. The symplectic Verlet's two evaluations are at t and
    t + dt/2."""
    over = [("dp", 0.1), ("output.vtk", False), ("output.progress", False)]
    a, b = wcsph.Simulation(load("moving_square_2d", over)), wcsph.Simulation(load("moving_square_2d", over))
    seen = []
    derivatives = b.model.derivatives

    def spy(*args, **kw):
        seen.append(b.walls_t)
        return derivatives(*args, **kw)

    while a.t < 1.2:
        dt = a.time_step()
        a.step(dt)
        b.step(dt)
    b.model.derivatives = spy
    dt = a.time_step()
    a.step(dt)
    t0 = b.t
    b.step(0.1 * dt)
    assert seen == pytest.approx([t0, t0 + 0.05 * dt], abs=1e-9)  # P.dt is in the case's precision
    b.step(0.9 * dt)
    assert b.walls_t == b.t and a.t == pytest.approx(b.t, abs=1e-12)
    for _ in range(20):
        a.step(a.time_step())
        b.step(b.time_step())
    fa, fb = a.body_loads()["square_fx"], b.body_loads()["square_fx"]
    assert abs(fb / fa - 1.0) < 1e-3, (fa, fb)


@pytest.mark.validation  # 20 across to 6 s: about three minutes here
def test_moving_square_keeps_the_box_mean_density_and_its_drag():
    """SPHERIC 6 (``moving_square_2d`` as shipped): the closed box's mean density stays within
    0.2 % of rho0 to t = 6 s (measured 0.09 %; with the shifting by the walls and the bounce at
    h_fac = 0.5 dp working against each other it rose 1.7 % at this resolution and the drag
    fell with resolution), and the mean C_D over 2-6 s, sampled every 0.05 s as the
    reference is, is within 10 % of the reference (the goal of 5 % is ``wcsph validate``'s
    check at 40 across)."""
    sim = wcsph.Simulation(load("moving_square_2d", [("time.end", 6.0), ("output.vtk", False)]))
    cd = []
    while sim.t < 6.0 - 1e-9:
        _advance(sim, round(sim.t + 0.05, 6))
        if sim.t >= 2.0 - 1e-9:
            cd.append(-2.0 * sim.body_loads()["square_fx"])
    rho, = sim.host(sim.fluid, "rho")
    assert abs(rho.mean() / 1.0 - 1.0) < 2e-3, rho.mean()
    rt, rcd = ref.moving_square_drag()
    mean_ref = rcd[(rt >= 2.0) & (rt <= 6.0)].mean()
    assert abs(np.mean(cd) / mean_ref - 1.0) < 0.10, np.mean(cd)


@pytest.mark.validation  # 20 across to 6 s: about two minutes here
def test_moving_square_with_boundary_particles_meets_the_reference_drag():
    """SPHERIC 6 in the classic model (``moving_square_2d_classic`` as shipped: wall
    particles, no-slip by Adami's velocity in the viscous terms, delta+ shifting) at 20
    across: the body's load, the reaction of the wall terms on the fluid, gives a mean C_D
    over 2-6 s within 5 % of the reference and an RMS of the difference, sampled every
    0.05 s, under 0.25. Measured 2026-12-08: +6.2 %, RMS 0.120 (40 across, the check: +7.7 %,
    RMS 0.132; -2.8 % while the continuity equation read the no-slip velocity too,
    docs/accuracy.md §4): the mean's 5 % is an open goal (``OPEN_GOALS``), reported as an
    expected failure while it is, and a mean 10 % off or an RMS over 0.25 fails. Without the
    shifting the mean is +15 % and the RMS 2.1: the wake tears."""
    sim = wcsph.Simulation(load("moving_square_2d_classic", [("time.end", 6.0), ("output.vtk", False)]))
    t, cd = [], []
    while sim.t < 6.0 - 1e-9:
        _advance(sim, round(sim.t + 0.05, 6))
        if sim.t >= 2.0 - 1e-9:
            t.append(sim.t)
            cd.append(-2.0 * sim.body_loads()["square_fx"])
    rt, rcd = ref.moving_square_drag()
    mean_ref = rcd[(rt >= 2.0) & (rt <= 6.0)].mean()
    rms = np.sqrt(np.mean((np.array(cd) - np.interp(t, rt, rcd)) ** 2))
    assert rms < 0.25, rms
    err = abs(np.mean(cd) / mean_ref - 1.0)
    assert err < 0.10, np.mean(cd)
    if err >= 0.05:
        pytest.xfail(f"open goal: mean C_D {np.mean(cd):.3f}, {err:.1%} from the reference (goal 5 %)")


@pytest.mark.validation
def test_open_channel_in_3d_with_a_periodic_span():
    """An open channel in 3D (as TNL-SPH's openChannel3D: inflow parabola, outflow p = 0),
    periodic across the span, 10 particles high: after 1.25 transits the downstream profile
    within 3 % of u_max (measured 1.8 %), no spanwise flow, the pressure drop 8 mu u_max L / H^2
    within 5 % (measured 1.30 against 1.28 Pa), particles created and removed alike."""
    case = validate({
        "dim": 3, "dp": 0.1, "precision": "float64",
        "fluid": [{"min": [0, 0, 0], "max": [1.6, 1.0, 1.0], "velocity": ["4*z*(1 - z)", 0.0, 0.0],
                   "pressure": "0.8*(1.6 - x)"}],
        "open_boundary": [
            {"kind": "inlet", "min": [-0.4, 0, 0], "max": [0, 1.0, 1.0], "normal": [1.0, 0, 0],
             "velocity": ["4*z*(1 - z)", 0.0, 0.0]},
            {"kind": "outlet", "min": [1.6, 0, 0], "max": [2.0, 1.0, 1.0], "normal": [-1.0, 0, 0], "pressure": 0.0}],
        "obstacle": [{"min": [-0.6, 0, -0.5], "max": [2.2, 1.0, 0.0]}, {"min": [-0.6, 0, 1.0], "max": [2.2, 1.0, 1.5]}],
        "domain": {"min": [-0.7, 0.0, -0.6], "max": [2.3, 1.0, 1.6], "periodic": [False, True, False]},
        "model": {"name": "bi", "BCType": "BIConservative_numeric", "ViscousTerm": "PhysicalViscosity_MVT",
                  "DiffusiveTerm": "MolteniDiffusiveTerm", "EOS": "LinearizedColeEquationOfState"},
        "parameters": {"rho0": 1.0, "speedOfSound": 10.0, "dynamicViscosity": 0.1, "delta": 0.1, "gravity": [0, 0, 0]},
        "time": {"end": 2.0}, "output": {"progress": False}})
    sim = wcsph.Simulation(case)
    _advance(sim, 2.0)
    x, v, kind, p = sim.host(sim.fluid, "x", "v", "kind", "p")
    fl = kind == 0
    down = fl & (x[0] > 0.8) & (x[0] < 1.6)
    assert np.sqrt(np.mean((v[0][down] - 4 * x[2][down] * (1 - x[2][down])) ** 2)) < 0.03
    assert np.abs(v[1][fl]).max() < 1e-6
    assert np.mean(p[fl & (x[0] < 0.1)]) == pytest.approx(0.8 * 1.6, rel=0.05)
    ob = sim.open.summary()
    assert ob["created"] > 1000 and abs(ob["created"] - ob["removed"]) <= 100


def _first_row_rates(wall_velocity, velocity, dp=0.02, dt=1e-5, model=None, bi=None):
    """(the density rate, the acceleration) of the row of wall particles' first fluid
    neighbours: a still-water box 10 dp high over a floor, periodic along x, every particle
    started at ``velocity``, one step of ``dt`` in the classic model with a continuity density
    and water's viscosity."""
    case = validate({
        "dim": 2, "dp": dp, "precision": "float64",
        "fluid": [{"min": [0.0, 0.0], "max": [10 * dp, 10 * dp], "velocity": list(velocity)}],
        "tank": {"min": [0.0, 0.0], "max": [10 * dp, 10 * dp], "open_top": False},
        "domain": {"periodic": [True, False]},
        "model": {"name": "classic", "density": "continuity", "DiffusiveTerm": "None", "xsph": "None",
                  "EOS": "LinearizedColeEquationOfState", "ViscousTerm": "PhysicalViscosity_MVT",
                  "dynamicViscosity": 1.0e-3, "wall_velocity": wall_velocity, **(model or {})} if bi is None else
                 {"name": "bi", "BCType": "BIConsistent_numeric", "DiffusiveTerm": "None",
                  "EOS": "LinearizedColeEquationOfState", "ViscousTerm": bi, "dynamicViscosity": 1.0e-3},
        "physics": {"rho0": 1000.0, "speed_of_sound": 20.0, "gravity": [0.0, 0.0]},
        "time": {"end": 1.0}, "output": {"vtk": False, "progress": False}})
    sim = wcsph.Simulation(case)
    x0, v0, rho0 = (a.astype(float) for a in sim.host(sim.fluid, "x", "v", "rho"))
    sim.step(dt)
    v1, rho1 = (a.astype(float) for a in sim.host(sim.fluid, "v", "rho"))
    row = np.abs(x0[1] - dp / 2) < dp / 4
    return np.mean((rho1 - rho0)[row]) / dt, np.mean((v1 - v0)[:, row], axis=1) / dt


def test_a_no_slip_wall_velocity_enters_the_viscous_terms_only():
    """Adami's no-slip velocity (2 v_w minus the fluid's, ``wall_velocity = "adami"``) is what
    the walls show the viscous terms; the continuity equation reads the wall's own velocity,
    as with ``"prescribed"`` (TrixiParticles.jl does the same). Read by the continuity
    equation too, the mirrored normal velocity doubled the walls' compression of the water
    flowing at them: Lobovsky's dam break ran away at the impact at dp = 0.0025
    (docs/accuracy.md §2c). Water sliding along the floor: the no-slip velocity doubles the
    viscous drag on the first row (measured 1.07 against 0.53 nu U / dp^2). Water flowing at
    the floor: the same density rate either way."""
    dp, U = 0.02, 0.1
    drho_p, a_p = _first_row_rates("prescribed", [0.0, -U], dp)
    drho_a, a_a = _first_row_rates("adami", [0.0, -U], dp)
    assert drho_p > 0  # the floor compresses the water flowing at it
    assert drho_a == pytest.approx(drho_p, rel=1e-6)  # (the step moves the rows by their viscous accelerations)
    _, s_p = _first_row_rates("prescribed", [U, 0.0], dp)
    _, s_a = _first_row_rates("adami", [U, 0.0], dp)
    nu = 1.0e-6
    assert s_p[0] < 0 and s_a[0] < 0  # both drag the sliding row back
    assert 1.8 < s_a[0] / s_p[0] < 2.2, (s_a[0], s_p[0])
    assert 0.8 < -s_a[0] / (nu * U / dp ** 2) < 1.4, s_a[0]


def test_monaghans_artificial_viscosity_reads_the_no_slip_velocity_too():
    """Pi_ij over the walls (``Monaghan1992ArtificialViscosity``, no other viscous term) is a
    viscous term: with Adami's no-slip velocity the water sliding along the floor meets a
    wall moving back at it, twice the relative speed, twice the drag; the density rate of
    water flowing at the floor is the same either way."""
    av = {"pressure": "Monaghan1992ArtificialViscosity", "ViscousTerm": "None", "dynamicViscosity": 0.0}
    _, s_p = _first_row_rates("prescribed", [0.1, 0.0], model=av)
    _, s_a = _first_row_rates("adami", [0.1, 0.0], model=av)
    assert s_p[0] < 0 and 1.9 < s_a[0] / s_p[0] < 2.1, (s_a[0], s_p[0])
    drho_p, _ = _first_row_rates("prescribed", [0.0, -0.1], model=av)
    drho_a, _ = _first_row_rates("adami", [0.0, -0.1], model=av)
    assert drho_a == pytest.approx(drho_p, rel=1e-4)  # (Pi pushes the rows apart unalike within the step)


def test_how_hard_each_wall_term_drags_the_first_row():
    """Water sliding at U along a floor, one step: the first row's deceleration in nu U / dp^2
    (a layer dp thick sheared over dp/2 by a no-slip wall: 2), the table of docs/accuracy.md
    §2c. WCSPH-BI's MVT boundary term 1.90, its MGVT term 4 times that (the spec's 2 (n + 2) mu
    on the unprojected (v_i - v_b) / d), the wall particles' Morris term 0.53 at the wall's
    velocity and 1.07 at Adami's no-slip one. On Lobovsky's wall the foot pressure follows
    this order; the drag grows as dp shrinks."""
    nu, U, dp = 1.0e-6, 0.1, 0.02
    drag = {}
    for label, kw in [("classic", {"wall_velocity": "prescribed"}), ("classic no-slip", {"wall_velocity": "adami"}),
                      ("MVT", {"wall_velocity": None, "bi": "PhysicalViscosity_MVT"}),
                      ("MGVT", {"wall_velocity": None, "bi": "PhysicalViscosity_MGVT"})]:
        _, a = _first_row_rates(kw.pop("wall_velocity"), [U, 0.0], dp, **kw)
        drag[label] = -a[0] / (nu * U / dp ** 2)
    assert drag["MGVT"] / drag["MVT"] == pytest.approx(4.0, rel=0.01), drag
    assert 1.7 < drag["MVT"] < 2.1 and 0.45 < drag["classic"] < 0.6 and 0.95 < drag["classic no-slip"] < 1.2, drag
