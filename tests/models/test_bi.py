"""WCSPH-BI: boundary elements, the four schemes against references, conservation, probes,
and the spec's parameter names."""
import copy
import csv

import numpy as np
import pytest

import wcsph
from wcsph.case import geometry
from wcsph.case.config import load, validate
from wcsph.errors import CaseError
from wcsph.physics.kernels import kernel_numpy

# one scheme in the default suite, the other three behind the validation marker (the default
# suite must stay within ten minutes on a cold two-core machine)
SCHEMES = [pytest.param(bc, visc, marks=[pytest.mark.validation] if (bc, visc) != ("BIConservative_numeric", "None")
                        else []) for bc in ("BIConservative_numeric", "BIConsistent_numeric")
           for visc in ("None", "PhysicalViscosity_MGVT")]


# ------------------------------------------------------------------ boundary elements
def test_element_normals_point_out_of_the_fluid():
    case = validate({"dim": 2, "dp": 0.1, "model": {"name": "bi"}, "time": {"end": 1.0},
                     "fluid": [{"min": [0.0, 0.0], "max": [0.5, 0.5]}],
                     "tank": {"min": [0.0, 0.0], "max": [2.0, 1.0]},
                     "obstacle": [{"min": [1.0, 0.0], "max": [1.4, 0.2]}]})
    x, n, s, body = geometry.boundary_elements(case, 0.1)
    assert np.allclose(np.linalg.norm(n, axis=0), 1)
    floor = (x[1] == 0) & (x[0] < 1.0)
    assert floor.any() and np.allclose(n[:, floor].T, [0, -1])          # tank floor
    assert np.allclose(n[:, x[0] == 0].T, [-1, 0])                      # left wall
    assert np.allclose(n[:, x[0] == 2.0].T, [1, 0])                     # right wall
    top = (x[1] == 0.2) & (x[0] > 1.0) & (x[0] < 1.4)
    assert top.any() and np.allclose(n[:, top].T, [0, -1])              # obstacle top: fluid above
    assert np.allclose(n[:, (x[0] == 1.0) & (x[1] > 0)].T, [1, 0])      # obstacle's left face
    # total length: floor 2, walls 2 x 1 (open top), obstacle 0.4 + 2 x 0.2 + 0.4 (its underside)
    assert s.sum() == pytest.approx(2 + 2 + 1.2)


def test_polygon_walls_have_the_fluid_on_their_left():
    x, n, s = geometry.polygon_elements([[0, 0], [1, 0], [1, 1]], False, 0.25)
    assert s.sum() == pytest.approx(2.0) and x.shape[1] == 8
    assert np.allclose(n[:, :4].T, [0, -1]) and np.allclose(n[:, 4:].T, [1, 0])


def _at_rest(bc, flip=False):
    """Fluid at rest at uniform pressure p0 = 1000 Pa with density rho0, no gravity: every
    acceleration should vanish, including next to the walls."""
    case = validate({"dim": 2, "dp": 0.02, "precision": "float64", "time": {"end": 1.0},
                     "physics": {"gravity": [0.0, 0.0], "speed_of_sound": 10.0, "p0": 1000.0},
                     "model": {"name": "bi", "BCType": bc, "DiffusiveTerm": "None"},
                     "fluid": [{"min": [0.0, 0.0], "max": [0.4, 0.4]}],
                     "tank": {"min": [0.0, 0.0], "max": [0.4, 0.4], "open_top": False}})
    sim = wcsph.Simulation(case)
    if flip:
        sim.walls["n"] = -sim.walls["n"]
    sim.evaluate(sim.model.update(sim.P, 1e-4, [0.0, 0.0]))
    a, = sim.host(sim.fluid, "dvdt")
    return np.abs(a).max()


@pytest.mark.parametrize("bc", ["BIConservative_numeric", "BIConsistent_numeric"])
def test_normal_convention_balances_a_uniform_pressure(bc):
    """The boundary integral must cancel the truncated bulk sum of a uniform pressure: with
    the normals as built the largest acceleration is a small quadrature remainder; with
    the normals flipped it doubles the wall force instead (and this test fails)."""
    p0_over_rho_h = 1000.0 / 1000.0 / 0.04  # the scale of a one-sided pressure force
    right, wrong = _at_rest(bc), _at_rest(bc, flip=True)
    assert right < 0.05 * p0_over_rho_h, right
    assert wrong > 0.5 * p0_over_rho_h, wrong


# ------------------------------------------------------------------ hydrostatic tank
@pytest.mark.parametrize("bc,visc", SCHEMES)
def test_hydrostatic_tank_each_scheme(bc, visc, tmp_path):
    """H = 0.5 m = 25 dp, tank 2 m wide, 2 s: the interior pressure profile, fitted and extrapolated to the
    floor and averaged over the last 0.5 s (acoustic oscillations of the column are undamped
    in the inviscid schemes), is rho0 g H within 2 %; no particle is behind a wall."""
    case = load("hydrostatic_2d_bi", [("model.BCType", bc), ("model.ViscousTerm", visc),
                                      ("model.dynamicViscosity", 1e-3), ("output.vtk", False)])
    sim = wcsph.Simulation(case)
    H, rho0, g = 0.5, 1000.0, 9.81
    bottom = []
    for t in np.arange(1.5, 2.0 + 1e-9, 0.05):
        sim.run(end_time=t, progress=False)
        x, p = sim.host(sim.fluid, "x", "p")
        sel = (np.abs(x[0] - 1.0) < 0.5) & (x[1] > 0.1 * H) & (x[1] < 0.8 * H)
        bottom.append(np.polyfit(x[1][sel], p[sel], 1)[1])
        assert x[0].min() > 0 and x[0].max() < 2 and x[1].min() > 0
    assert np.mean(bottom) == pytest.approx(rho0 * g * H, rel=0.02), np.array(bottom) / (rho0 * g * H)
    assert sim.dropped == 0


# ------------------------------------------------------------------ dam break
@pytest.mark.validation  # the same run as wcsph validate's surge-front check
def test_dam_break_surge_front_martin_moyce(martin_moyce_errors, tmp_path):
    """Column a = 0.25 m, 2a high, 50 particles across, the model of the shipped
    dam_break_2d_bi (water's viscosity, no artificial one, free-slip walls): the front within
    5 % of every Martin & Moyce (1952) point with T = t sqrt(2g/a) <= 3, once the experiment's
    release delay is fitted (measured 4.0 %)."""
    import copy

    from wcsph.validation import DAM_BREAK_BI

    a, g = 0.25, 9.81
    case = copy.deepcopy(DAM_BREAK_BI)
    case["time"]["end"] = 3.0 / np.sqrt(2 * g / a)
    case["output"].update({"progress": False, "surge_front": True, "interval": 0.002})
    wcsph.run(case, output=tmp_path)
    T, err = martin_moyce_errors(tmp_path / "probes.csv", a)
    assert np.all(np.abs(err) < 0.05), dict(zip(T, np.round(err, 3)))


def _energy_ratio(tmp_path, *overrides):
    """(kinetic energy gained) / (potential energy lost) of dam_break_3d_bi to t = 0.15 s."""
    s = wcsph.run("dam_break_3d_bi", output=tmp_path, progress=False, overrides=[
        ("dp", 0.04), ("time.end", 0.15), ("output.vtk", False), *overrides])
    assert s["dim"] == 3 and s["dropped"] == 0
    with open(tmp_path / "probes.csv") as f:
        rows = list(csv.DictReader(f))
    ek = [float(r["kinetic_energy"]) for r in rows]
    ep = [float(r["potential_energy"]) for r in rows]
    assert ek[-1] > 0 and ep[-1] < ep[0]
    return (ek[-1] - ek[0]) / (ep[0] - ep[-1])


@pytest.mark.validation  # the 3D WCSPH-BI loops run in the default suite in test_cuda_sim (bi-3d)
def test_dam_break_3d_bi_stays_physical(tmp_path):
    """The shipped 3D case with the conservative scheme, the one whose wall terms are
    antisymmetric: the kinetic energy gained is at most the potential energy lost (+1 %;
    measured 0.998). The shipped consistent scheme renormalizes the sums next to walls and
    does not conserve energy: with the shipped Fourtakas diffusion it gains 3.6 % more kinetic
    energy than the potential energy lost at dp = 0.04, 2.1 % at 0.03 and 1.8 % at 0.02 (with
    Molteni's, which also damps the density's acoustic oscillations: 3.0, 1.7 and 1.5 %; about
    1 % is the elastic energy of the hydrostatic start, 0.44 J); asserted: below 4 % and
    smaller at dp = 0.03 than at 0.04."""
    assert _energy_ratio(tmp_path / "conservative", ("model.BCType", "BIConservative_numeric")) <= 1.01
    coarse = _energy_ratio(tmp_path / "coarse")
    finer = _energy_ratio(tmp_path / "finer", ("dp", 0.03))
    assert coarse < 1.04 and finer < coarse, (coarse, finer)


# ------------------------------------------------------------------ conservation
def _random_patch(walls):
    rng = np.random.default_rng(1)
    case = {"dim": 2, "dp": 0.02, "precision": "float64", "time": {"end": 1.0, "dt": 2e-4},
            "physics": {"gravity": [0.0, 0.0], "speed_of_sound": 20.0},
            "model": {"name": "bi", "BCType": "BIConservative_numeric", "DiffusiveTerm": "MolteniDiffusiveTerm",
                      "enableElasticBounce": False, "enableNearBoundaryShifting": False},
            "fluid": [{"min": [0.0, 0.0], "max": [0.4, 0.4]}]}
    if walls:
        case["tank"] = {"min": [0.0, 0.0], "max": [0.4, 0.4], "open_top": False}
    sim = wcsph.Simulation(validate(case))
    sim.fluid["v"] = rng.normal(0, 0.3, sim.fluid["v"].shape)
    return sim


def _momenta(sim):
    x, v, m = sim.host(sim.fluid, "x", "v", "m")
    return (m * v).sum(axis=1), float((m * (x[0] * v[1] - x[1] * v[0])).sum())


def test_conservative_scheme_conserves_momentum_without_walls():
    """An inviscid fluid patch with random velocities, no gravity, no walls: 300 steps of
    symplectic Verlet keep linear and angular momentum to round-off (pair forces are
    antisymmetric and central)."""
    sim = _random_patch(walls=False)
    P0, L0 = _momenta(sim)
    scale = float((sim.host(sim.fluid, "m")[0] * np.abs(sim.host(sim.fluid, "v")[0]).sum(axis=0)).sum())
    for _ in range(300):
        sim.step(2e-4)
    P1, L1 = _momenta(sim)
    assert np.abs(P1 - P0).max() < 1e-12 * scale, P1 - P0
    assert abs(L1 - L0) < 1e-12 * scale, L1 - L0
    assert np.abs(sim.host(sim.fluid, "drhodt")[0]).max() > 1  # the fluid is being compressed


def test_conservative_scheme_closed_box_momentum_balance():
    """In a closed box (no gravity, inviscid) the fluid's total force and torque equal
    those of the boundary-integral wall force alone, computed independently from the spec's
    formula -2 p_i V_i sum_b n_b W_ib S_b: the fluid pairs add nothing, to round-off."""
    sim = _random_patch(walls=True)
    for _ in range(50):
        sim.step(2e-4)
    sim.evaluate(sim.P)
    x, a, p, rho, m = sim.host(sim.fluid, "x", "dvdt", "p", "rho", "m")
    xb, nb, sb = sim.host(sim.walls, "x", "n", "elementSize")
    w, _ = kernel_numpy("wendland", 2, sim.h)
    r = np.sqrt(((x[:, :, None] - xb[:, None, :]) ** 2).sum(axis=0))
    f_wall = -2 * (p * m / rho)[None, :] * np.einsum("db,ib->di", nb, w(r) * sb)
    force = m * a
    assert np.abs(f_wall).sum() > 1e-3 * np.abs(force).sum()  # the walls do push
    scale = np.abs(force).sum()
    assert np.abs(force.sum(axis=1) - f_wall.sum(axis=1)).max() < 1e-10 * scale
    torque = (x[0] * force[1] - x[1] * force[0]).sum()
    torque_wall = (x[0] * f_wall[1] - x[1] * f_wall[0]).sum()
    assert abs(torque - torque_wall) < 1e-10 * scale


# ------------------------------------------------------------------ probes
def test_probes_read_the_still_water(tmp_path):
    """At t = 0 in the hydrostatic tank: the level gauge reads the depth within dp/4, the
    mid-depth sensor rho0 g H/2 within 1 %; columns are named after the probes."""
    # the scheme of the default suite's hydrostatic test (its loops are compiled once)
    case = load("hydrostatic_2d_bi", [("time.end", 0.001), ("output.vtk", False),
                                      ("model.BCType", "BIConservative_numeric"), ("model.ViscousTerm", "None")])
    sim = wcsph.Simulation(case)
    values = sim.probes.sample()
    assert set(values) == {"p_bottom", "p_mid", "level"}
    assert values["level"] == pytest.approx(0.5, abs=0.25 * case["dp"])
    assert values["p_mid"] == pytest.approx(1000 * 9.81 * 0.25, rel=0.01)
    sim.run(output=tmp_path, progress=False)
    header = (tmp_path / "probes.csv").read_text().splitlines()[0].split(",")
    assert header[-3:] == ["p_bottom", "p_mid", "level"]


def test_volume_gauge_reads_the_column_of_water():
    """A level gauge of method "volume" reads the base plus the water's volume per unit area
    above it: in the still tank (lattice, hydrostatic density) the depth less the column's
    compression, g H / (2 c0^2) of H; above a raised base only what lies above it; in 3D
    the same with the 2D kernel over the horizontal plane."""
    for name, x in (("hydrostatic_2d_bi", [1.0, 0.0]), ("dam_break_3d_bi", [0.15, 0.2, 0.0])):
        gauges = [{"name": "v0", "kind": "level", "method": "volume", "position": x},
                  {"name": "v1", "kind": "level", "method": "volume", "position": x[:-1] + [0.1]}]
        case = load(name, [("time.end", 0.001), ("output.vtk", False), ("probes", gauges)])
        sim = wcsph.Simulation(case)
        values = sim.probes.sample()
        H = case["fluid"][0]["max"][-1]
        squeeze = 9.81 * H / (2 * sim.c0**2) * H
        assert values["v0"] == pytest.approx(H - squeeze, abs=0.1 * case["dp"]), name
        assert values["v1"] == pytest.approx(values["v0"], abs=0.1 * case["dp"]), name


def test_extrapolated_sensor_reads_the_wall_pressure():
    """A sensor on the floor of the still tank: the Shepard mean over its one-sided support
    reads the pressure of the water above it (several % low); carried along the momentum
    equation's pressure gradient (``extrapolate``) it reads rho0 g H within 1 %."""
    probes = [{"name": "p_floor", "kind": "pressure", "position": [1.0, 0.0]},
              {"name": "p_floor_x", "kind": "pressure", "position": [1.0, 0.0], "extrapolate": True},
              {"name": "p_mid_x", "kind": "pressure", "position": [1.0, 0.25], "extrapolate": True}]
    case = load("hydrostatic_2d_bi", [("time.end", 0.001), ("output.vtk", False), ("probes", probes),
                                      ("model.BCType", "BIConservative_numeric"), ("model.ViscousTerm", "None")])
    values = wcsph.Simulation(case).probes.sample()
    rgh = 1000 * 9.81 * 0.5
    assert values["p_floor_x"] == pytest.approx(rgh, rel=0.01)
    assert values["p_floor"] < 0.97 * rgh
    assert values["p_mid_x"] == pytest.approx(rgh / 2, rel=0.01)


def test_tank_load_is_the_weight_of_the_water():
    """The still tank's walls named as a body: in the hydrostatic start the fluid's load on
    them (the elements' own pressure, ``physics.loads``) is the weight of the water to 0.2 %,
    downwards, with no sideways force."""
    # the scheme of the default suite's hydrostatic test (its loops are compiled once)
    case = load("hydrostatic_2d_bi", [("output.vtk", False), ("tank.name", "tank"),
                                      ("model.BCType", "BIConservative_numeric"), ("model.ViscousTerm", "None")])
    sim = wcsph.Simulation(case)
    weight = float(np.sum(sim.host(sim.fluid, "m")[0])) * 9.81
    loads = sim.body_loads()
    assert loads["tank_fy"] == pytest.approx(-weight, rel=0.002)
    assert abs(loads["tank_fx"]) < 1e-4 * weight


@pytest.mark.validation
def test_settled_tank_load_is_the_weight_of_the_water():
    """The shipped (consistent) still tank after settling: the load on its walls averaged over
    1-2 s is the weight of the water within 1.5 % (measured -0.9 %: the tank is never quite
    at rest, its particles drift at up to 0.14 m/s and single samples scatter by 2 %)."""
    case = load("hydrostatic_2d_bi", [("time.end", 2.0), ("output.vtk", False), ("tank.name", "tank")])
    sim = wcsph.Simulation(case)
    weight = float(np.sum(sim.host(sim.fluid, "m")[0])) * 9.81
    fy = []
    for k in range(21):
        t = 1.0 + 0.05 * k
        while sim.t < t - 1e-9:
            sim.step(min(sim.time_step(), t - sim.t))
        loads = sim.body_loads()
        fy.append(loads["tank_fy"])
        assert abs(loads["tank_fx"]) < 1e-2 * weight
    assert np.mean(fy) == pytest.approx(-weight, rel=0.015)


def test_spheric2_figures_of_the_experiment():
    """The figures the SPHERIC 2 check compares, taken from the shipped measurements, are
    those published for the experiment (Kleefsman et al. 2005, as the project's issue quotes
    them): arrivals to the millisecond, means to 0.5 %."""
    from wcsph.validation import spheric2

    f = spheric2.figures(spheric2.experiment())
    assert f["P1 impact"] == pytest.approx(0.395, abs=1e-3)
    assert f["H3 wet"] == pytest.approx(0.218, abs=1e-3) and f["H2 wet"] == pytest.approx(0.368, abs=1e-3)
    assert f["P1 mean"] == pytest.approx(3459, rel=0.005) and f["P3 mean"] == pytest.approx(3193, rel=0.005)
    assert f["H4 mean"] == pytest.approx(0.287, rel=0.005) and f["H1 mean"] == pytest.approx(0.132, rel=0.005)
    rows = {r[0]: r for r in spheric2.compare(dict(f, **{"P1 impact": f["P1 impact"] + 0.03}))}
    assert not rows["P1 impact"][5] and rows["P1 mean"][5]  # 30 ms late fails, the means pass


def test_probe_outside_domain_is_a_case_error():
    case = load("hydrostatic_2d_bi", [("probes", [{"name": "far", "kind": "pressure", "position": [9.0, 0.1]}])])
    with pytest.raises(CaseError, match=r"probes\[0\].position: .* outside the domain"):
        wcsph.Simulation(case)


# ------------------------------------------------------------------ parameters
def test_spec_parameter_names_and_derived_defaults():
    case = load("dam_break_2d_bi", [("dp", 0.02)])
    assert case["physics"]["rho0"] == 997.0 and case["physics"]["speed_of_sound"] == 17.155
    assert case["model"]["h"] == 0 and case["model"]["dynamicViscosity"] == 1e-3
    assert case["model"]["delta"] == 0.1 and case["model"]["alpha"] == 0.02  # spec defaults
    assert case["model"]["r_boxFactor"] == 1.5 and case["model"]["minimalDistanceFactor"] == 0.5
    # --set on a spec name given under [parameters] changes it there
    assert load("dam_break_2d_bi", [("model.delta", 0.05)])["model"]["delta"] == 0.05
    assert load("dam_break_2d_bi", [("parameters.delta", 0.2)])["model"]["delta"] == 0.2
    # left at 0: h = 2 dp, searchRadius = 2h, mass = rho0 dp^2, element size dp
    sim = wcsph.Simulation(load("hydrostatic_2d_bi"))
    assert sim.h == pytest.approx(0.04) and sim.grid.support == pytest.approx(0.08)
    assert sim.mass == pytest.approx(1000 * 0.02**2)
    assert np.allclose(sim.host(sim.walls, "elementSize")[0], 0.02)


@pytest.mark.parametrize("data,message", [
    ({"parameters": {"deltaa": 0.1}}, "parameters.deltaa: unknown parameter"),
    ({"parameters": {"delta": 0.1}, "model": {"name": "bi", "delta": 0.2}}, "parameters.delta: also given"),
    ({"model": {"name": "bi", "wall_layers": 2}}, "model.wall_layers: applies to model.BCType = "
     "'AkinciBoundaryParticles', not to model.BCType = 'BIConservative_numeric'"),
    ({"model": {"name": "classic", "DiffusiveTerm": "MolteniDiffusiveTerm"}},
     "model.DiffusiveTerm: 'MolteniDiffusiveTerm' needs model.density = 'continuity', not 'summation'"),
    ({"model": {"name": "bi", "density": "summation"}}, "model.density: 'summation' needs boundary particles, "
     "which model.BCType = 'BIConservative_numeric' does not give"),
    ({"model": {"name": "bi", "elasticFactor": 0.5}}, "model.elasticFactor: 0.5 has no effect with "
     "elasticBounce = 'conservative'"),
    ({"model": {"name": "bi", "xsph": 0.1}}, "model.xsph: expected a string, got 0.1"),
    ({"model": {"name": "bi", "ViscousTerm": "Laminar"}}, "model.ViscousTerm: must be one of"),
    ({"model": {"name": "bi", "elasticFactor": 2.0}}, "model.elasticFactor: must lie in [0, 1]"),
    ({"model": {"name": "bi", "ViscousTerm": "ArtificialViscosity", "pressure": "Monaghan1992ArtificialViscosity"}},
     "model.pressure: 'Monaghan1992ArtificialViscosity' carries an artificial viscosity"),
])
def test_bi_case_errors_name_the_key(data, message):
    base = {"dim": 2, "dp": 0.05, "time": {"end": 0.1}, "fluid": [{"min": [0.0, 0.0], "max": [0.5, 0.5]}],
            "model": {"name": "bi"}}
    base.update(copy.deepcopy(data))
    with pytest.raises(CaseError, match=message.replace("[", r"\[").replace("]", r"\]")):
        validate(base, src="c.toml")


def test_spheric2_reservoir_lead_reads_a_shift_of_the_record():
    """The reservoir lead of the SPHERIC 2 check is the shift that lays a run's H4 over the
    experiment's drop: the record itself reads 0, the record 15 ms late reads 15 ms, 20 ms early
    reads -20 ms, to the fit's 0.1 ms step, and so does each 3 mm low (a compressed column's
    start, which the level would have read as about 10 ms)."""
    from wcsph.validation import spheric2

    t, h = spheric2.experiment()["H4"]
    for shift in (0.0, 0.015, -0.02):
        for low in (0.0, 0.003):
            assert spheric2.reservoir_lead({"H4": (t + shift, h - low)}) == pytest.approx(shift, abs=1e-4)


def test_a_fitted_fluid_box_holds_the_water_it_is_drawn_with():
    """The still tank 0.5 m deep at dp = 0.035, where whole spacings of dp hold 14 of them
    (0.49 m, 2 % short): with ``fill = "fitted"`` the box holds round(L/dp) spacings of L/n
    along each axis and each particle the mass of its cell, so the water's mass is rho0 times
    the box to round-off, its particles lie half a cell inside each face, and the tank's load
    at the hydrostatic start is the drawn column's weight within 0.2 %. The plain lattice's
    water is 2.2 % short of it (0.49 m deep, 1.995 m wide), and its start's pressure is that of
    the depth it holds (the load rho0 g 0.49 m over the floor within 0.2 %; until 2026-12-07
    the drawn depth's, 2 % more)."""
    rgh_l = 1000.0 * 9.81 * 0.5 * 2.0  # the drawn column's weight per unit width [N/m]
    loads = {}
    for fill in ("lattice", "fitted"):
        case = load("hydrostatic_2d_bi", [("dp", 0.035), ("time.end", 0.001), ("output.vtk", False),
                                          ("tank.name", "tank"), ("fluid", [{"min": [0.0, 0.0], "max": [2.0, 0.5],
                                                                             "fill": fill}]),
                                          ("model.BCType", "BIConservative_numeric"), ("model.ViscousTerm", "None")])
        sim = wcsph.Simulation(case)
        x = sim.host(sim.fluid, "x")[0]
        m = sim.host(sim.fluid, "m")[0]
        loads[fill] = sim.body_loads()["tank_fy"]
        if fill == "fitted":
            assert x.shape[1] == 57 * 14 and float(np.sum(m)) == pytest.approx(1000.0 * 2.0 * 0.5, rel=1e-5)
            assert x[1].max() == pytest.approx(0.5 - 0.25 / 14, abs=1e-5) and x[0].min() == pytest.approx(1.0 / 57, abs=1e-5)
            assert not any("fluid[0]" in w for w in sim.warnings)
        else:
            assert any(w.startswith("fluid[0] is 0.5 m along axis 1 and holds 14 spacings") for w in sim.warnings)
            assert float(np.sum(m)) == pytest.approx(1000.0 * 57 * 0.035 * 14 * 0.035, rel=1e-5)
    assert loads["fitted"] == pytest.approx(-rgh_l, rel=0.002)
    assert loads["lattice"] == pytest.approx(-9.81 * 1000.0 * 2.0 * 14 * 0.035, rel=0.002)


def test_a_fitted_fluid_box_is_refused_for_a_summation_density_column_at_rest():
    """A summation density's column at rest is sampled compressed, layer by layer: a fitted
    box under it is a case error naming the key (with a gravity ramp the column starts on
    the lattice and a fitted box is taken)."""
    with pytest.raises(CaseError, match=r"fluid\[0\]\.fill: \"fitted\" does not take a summation density's column at rest"):
        wcsph.Simulation(load("hydrostatic_2d", [("dp", 0.05), ("physics.gravity_ramp_time", 0.0),
                                                 ("fluid", [{"min": [0.0, 0.0], "max": [1.0, 0.5], "fill": "fitted"}])]))
    ramped = wcsph.Simulation(load("hydrostatic_2d", [("dp", 0.05), ("physics.gravity_ramp_time", 0.5),
                                                      ("fluid", [{"min": [0.0, 0.0], "max": [1.0, 0.53], "fill": "fitted"}])]))
    assert float(np.sum(ramped.host(ramped.fluid, "m")[0])) == pytest.approx(ramped.mass / 0.05 ** 2 * 0.53, rel=1e-5)
