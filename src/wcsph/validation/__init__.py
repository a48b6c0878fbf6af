"""``wcsph validate``: the validation set, each case run and compared with its reference
(``references``: published data shipped in ``data/``, analytic solutions), and one report.

Every check returns a ``Result``: the measured figure, the tolerance it must meet, and the
curves of its plot. ``run_all`` writes ``report.md`` (a pass/fail table, then one section and
one PNG per check) atomically into the output directory. ``--quick`` runs the checks marked
quick (a few minutes on two cores); the full set adds the dam breaks, the classic wall model
and the convergence studies.
"""
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import CaseError, SimulationError
from . import references as ref


@dataclass
class Result:
    name: str
    what: str  # the figure compared, in words
    reference: str  # what it is compared with (and the source)
    measured: float
    tolerance: float
    passed: bool
    detail: str = ""
    curves: list = field(default_factory=list)  # (label, x, y, kind: 'sim' | 'ref' | 'other' | 'data')
    axes: tuple = ("", "")
    seconds: float = 0.0
    check: str = ""  # the function's name


def _sim(case, overrides=()):
    """A Simulation of a shipped case name, or of a case dict, with ``KEY=VALUE`` overrides."""
    import copy
    import warnings

    from ..case.config import apply_override, load, validate
    from ..solver.simulation import Simulation

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if isinstance(case, dict):
            data = copy.deepcopy(case)
            for key, value in overrides:
                apply_override(data, key, value)
            return Simulation(validate(data, "<validation>"))
        return Simulation(load(case, list(overrides)))


def _advance(sim, t):
    while sim.t < t - 1e-12 * max(t, 1.0):
        sim.step(min(sim.time_step(), t - sim.t))


def _profile_check(name, case_name, exact, times, scale, overrides=(), tol=0.01):
    """Run ``case_name`` and compare u_x(y) with ``exact(y, t)`` at ``times``: the L2 error
    over all particles relative to ``scale`` (the steady peak velocity), the largest of the
    times."""
    sim = _sim(case_name, overrides)
    errors, curves = [], []
    for t in times:
        _advance(sim, t)
        x, v = (a.astype(float) for a in sim.host(sim.fluid, "x", "v"))
        e = math.sqrt(float(np.mean((v[0] - exact(x[1], sim.t)) ** 2))) / scale
        errors.append(e)
        order = np.argsort(x[1])
        yy = np.linspace(0, x[1].max() + 0.5 * sim.dp, 200)
        curves += [(f"t = {t:g} s", v[0][order], x[1][order], "sim"), (None, exact(yy, sim.t), yy, "ref")]
    worst = max(errors)
    return Result(name, "L2 error of u_x / u_max, largest over t = " + ", ".join(f"{t:g}" for t in times),
                  "Morris, Fox & Zhu (1997) series solution", worst, tol, worst < tol,
                  "errors " + ", ".join(f"{e:.2%}" for e in errors) + f"; {sim.fluid.n} fluid particles",
                  curves, ("u_x [m/s]", "y [m]"))


def poiseuille(quick, overrides=(), name="Poiseuille, periodic, WCSPH-BI"):
    L, F, nu = 1e-3, 2e-4, 1e-6
    return _profile_check(name, "poiseuille_2d", lambda y, t: ref.poiseuille(y, t, L, F, nu), (0.1, 0.3, 1.0),
                          F * L**2 / (8 * nu), overrides)


def couette(quick, overrides=(), name="Couette, moving wall, WCSPH-BI"):
    L, U, nu = 1e-3, 2.5e-5, 1e-6
    return _profile_check(name, "couette_2d", lambda y, t: ref.couette(y, t, L, U, nu), (0.05, 0.2, 1.0), U,
                          overrides)


def poiseuille_open(quick, overrides=(), times=(1.0, 2.0, 4.0)):
    """The open channel (inflow profile, outflow pressure): the velocity profile in the
    downstream half against the inflow parabola, at t = 1, 2, 4 s (two transits)."""
    sim = _sim("poiseuille_open_2d", overrides)
    errors, curves = [], []
    for t in times:
        _advance(sim, t)
        x, v, kind, p = (a.astype(float) for a in sim.host(sim.fluid, "x", "v", "kind", "p"))
        down = (kind == 0) & (x[0] > 1.0) & (x[0] < 2.0)
        exact = 4 * x[1] * (1 - x[1])
        errors.append(math.sqrt(float(np.mean((v[0][down] - exact[down]) ** 2))))
        order = np.argsort(x[1][down])
        curves.append((f"t = {t:g} s", v[0][down][order], x[1][down][order], "sim"))
    yy = np.linspace(0, 1, 100)
    curves.append(("inflow 4 y (1 - y)", 4 * yy * (1 - yy), yy, "ref"))
    inlet = (kind == 0) & (x[0] < 0.1)
    worst = max(errors)
    return Result("Poiseuille, open inlet and outlet, WCSPH-BI",
                  "L2 error of u_x / u_max, 1 < x < 2 m, largest over t = " + ", ".join(f"{t:g}" for t in times) + " s",
                  "the inflow profile (fully developed Poiseuille flow)", worst, 0.02, worst < 0.02,
                  "errors " + ", ".join(f"{e:.2%}" for e in errors) + f"; pressure near the inlet "
                  f"{np.mean(p[inlet]):.3f} Pa (8 mu u_max L / H^2 = 1.6 Pa); particles created "
                  f"{sim.open.created}, removed {sim.open.removed}", curves, ("u_x [m/s]", "y [m]"))


#: SPHERIC 2 with the classic model: the settings of ``dam_break_3d`` (continuity density with
#: Fourtakas' diffusion, the linear EOS unclamped, no XSPH, water's viscosity, Adami's wall
#: pressure, no wall friction) on the same geometry
SPHERIC2_CLASSIC = [("model", {"name": "classic", "density": "continuity", "DiffusiveTerm": "FourtakasDiffusiveTerm",
                               "EOS": "LinearizedColeEquationOfState", "xsph": "None",
                               "ViscousTerm": "PhysicalViscosity_MVT", "dynamicViscosity": 1.0e-3})]

#: the classic model on the same channels: Akinci walls with the no-slip velocity of Adami et
#: al. (2012), density summation, Tait EOS, Morris viscosity, no XSPH
CLASSIC = [("model.name", "classic"), ("model.BCType", "AkinciBoundaryParticles"), ("model.xsph", "None"),
           ("model.DiffusiveTerm", "None"), ("model.EOS", "TaitEquationOfState"), ("model.density", "summation"),
           ("model.wall_velocity", "adami")]


def poiseuille_classic(quick):
    return poiseuille(quick, CLASSIC, "Poiseuille, periodic, classic (Adami no-slip walls)")


def couette_classic(quick):
    return couette(quick, CLASSIC, "Couette, moving wall, classic (Adami no-slip walls)")


def _tg_rate(dp, end=1.0):
    sim = _sim("taylor_green_2d", [("dp", dp), ("time.end", end)])
    ts, ks = [], []
    for k in range(21):
        _advance(sim, end * k / 20)
        v, m = (a.astype(float) for a in sim.host(sim.fluid, "v", "m"))
        ts.append(sim.t)
        ks.append(0.5 * float(np.sum(m * (v**2).sum(0))))
    ts, ks = np.array(ts), np.array(ks)
    return np.polyfit(ts, np.log(ks / ks[0]), 1)[0], ts, ks / ks[0]


def taylor_green(quick):
    exact = ref.taylor_green_decay_rate(100.0)
    rate, ts, ks = _tg_rate(0.01)
    err = abs(rate / exact - 1)
    return Result("Taylor-Green vortex, Re = 100, 100 x 100", "decay rate of E_k (fit of ln E_k, 0 <= t <= 1)",
                  "exp(-16 pi^2 t / Re) (Taylor & Green 1937)", err, 0.02, err < 0.02,
                  f"rate {rate:.4f} against {exact:.4f}; delta+ shifting, MVT viscosity, Molteni diffusion",
                  [("SPH", ts, ks, "sim"), ("exact", ts, np.exp(exact * ts), "ref")], ("t [s]", "E_k / E_k(0)"))


def _convergence(name, dps, errors, what):
    order = np.polyfit(np.log(dps), np.log(errors), 1)[0]
    return Result(name, f"measured order of the {what} (fit over dp = " + ", ".join(f"{d:g}" for d in dps) + ")",
                  "at least first order", order, 1.0, bool(order >= 1.0),
                  "errors " + ", ".join(f"{e:.3%}" for e in errors),
                  [("SPH", np.asarray(dps), np.asarray(errors), "sim"),
                   ("order 1", np.asarray(dps), errors[-1] * (np.asarray(dps) / dps[-1]), "ref"),
                   ("order 2", np.asarray(dps), errors[-1] * (np.asarray(dps) / dps[-1]) ** 2, "ref")],
                  ("dp [m]", "error"))


def _tg_field_error(dp, t=1.0):
    """Relative L2 error of the velocity field against the exact vortex at time t."""
    sim = _sim("taylor_green_2d", [("dp", dp), ("time.end", t)])
    _advance(sim, t)
    x, v = (a.astype(float) for a in sim.host(sim.fluid, "x", "v"))
    u = ref.taylor_green_velocity(x, sim.t, 100.0)
    return math.sqrt(float(np.mean(((v - u) ** 2).sum(axis=0))) / float(np.mean((u**2).sum(axis=0))))


def convergence_taylor_green(quick):
    """The velocity field's error at t = 1 (the decay rate's error changes sign with dp, so
    it is no measure of order)."""
    dps = [0.04, 0.02, 0.01]
    errs = [_tg_field_error(dp) for dp in dps]
    return _convergence("Convergence, Taylor-Green", dps, errs, "L2 velocity error at t = 1")


def convergence_poiseuille(quick):
    L, F, nu = 1e-3, 2e-4, 1e-6
    dps = [1e-4, 5e-5, 2.5e-5]  # 10, 20, 40 across; a channel 1 mm long (2.5 supports at the coarsest)
    long = [("fluid", [{"min": [0.0, 0.0], "max": [1e-3, 1e-3]}]), ("tank.max", [1e-3, 1e-3])]
    errs = [poiseuille(quick, [("dp", dp)] + long).measured for dp in dps]
    return _convergence("Convergence, Poiseuille", dps, errs, "L2 velocity error")


def _hydrostatic(case_name, label, overrides=()):
    """The still tank: a sensor on the floor at the tank's middle (carried to the wall along
    the momentum equation, ``extrapolate``), its mean over 1.5-2 s, against the weight of
    the water per unit width, M g / L (scored, within 1 %); the interior's pressure profile at
    2 s, fitted and extrapolated to the floor, against rho0 g H (shown)."""
    case = _sim(case_name).case
    lo, hi = case["tank"]["min"], case["tank"]["max"]
    floor = [{"name": "floor", "kind": "pressure", "position": [0.5 * (lo[0] + hi[0]), lo[1]], "extrapolate": True}]
    sim = _sim(case_name, [("time.end", 2.0), ("probes", floor)] + list(overrides))
    _advance(sim, 1.5)
    readings = []  # every 10 ms over the last 0.5 s: the column's acoustic swing is undamped in WCSPH-BI
    for k in range(1, 51):
        _advance(sim, 1.5 + 0.01 * k)
        readings.append(float(sim.probes.sample()["floor"]))
    sim.model.refresh(sim.fluid, sim.P)
    x, p = (a.astype(float) for a in sim.host(sim.fluid, "x", "p"))
    H, rho0, g = 0.5, float(sim.rho0), 9.81
    weight = float(np.sum(sim.host(sim.fluid, "m")[0].astype(float))) * g / (hi[0] - lo[0])
    p_sensor = float(np.mean(readings))
    err = abs(p_sensor / weight - 1)
    sel = (x[1] > 0.1 * H) & (x[1] < 0.8 * H) & (np.abs(x[0] - 0.5 * (x[0].min() + x[0].max())) < 0.3)
    slope, p_floor = np.polyfit(x[1][sel], p[sel], 1)
    yy = np.linspace(0, H, 50)
    return Result(f"Hydrostatic tank, {label}", "floor sensor, mean over 1.5-2 s / (M g / L) - 1",
                  "M g / L", err, 0.01, err < 0.01,
                  f"floor sensor {p_sensor:.1f} Pa (from {min(readings):.1f} to {max(readings):.1f}), M g / L {weight:.1f} Pa; the interior's profile extrapolated to "
                  f"the floor {p_floor:.1f} Pa, {p_floor / (rho0 * g * H) - 1:+.4f} of rho0 g H",
                  [("SPH", p, x[1], "sim"), ("rho0 g (H - y)", rho0 * g * (H - yy), yy, "ref")], ("p [Pa]", "y [m]"))


#: 50 particles deep: at the cases' own 25 the WCSPH-BI sensor reads 1.2 % below the weight (the
#: classic +0.3 %), at 50 within 0.1 % (docs/accuracy.md §4)
HYDROSTATIC_DP = 0.01


def hydrostatic_classic(quick):
    return _hydrostatic("hydrostatic_2d", "classic", [("dp", HYDROSTATIC_DP)])


def hydrostatic_bi(quick):
    return _hydrostatic("hydrostatic_2d_bi", "WCSPH-BI", [("dp", HYDROSTATIC_DP)])


def _dam_break(label, case_name, overrides, a):
    """The surge front of a column a wide and 2a high, released at once, against Martin &
    Moyce (1952) (scored) and Koshizuka & Oka (1996) (shown) for T = t sqrt(2g/a) <= 3. Each
    experiment's time origin is its release: the front is compared with the data taken a
    release delay later, fitted once per experiment in [0, MAX_RELEASE_DELAY]
    (``references.surge_front_error``; docs/accuracy.md, "Surge fronts")."""
    g = 9.81
    end = 3.0 / math.sqrt(2 * g / a)
    sim = _sim(case_name, list(overrides) + [("time.end", end)])
    ts, zs = [], []
    for k in range(121):
        _advance(sim, end * k / 120)
        x = sim.host(sim.fluid, "x")[0]
        ts.append(sim.t * math.sqrt(2 * g / a))
        zs.append((float(x[0].max()) + 0.5 * sim.dp) / a)
    T, Z = np.array(ts), np.array(zs)
    delay, _, err = ref.surge_front_error(T, Z, "martin_moyce_1952")
    _, _, err0 = ref.surge_front_error(T, Z, "martin_moyce_1952", max_delay=0.0)
    k_delay, _, k_err = ref.surge_front_error(T, Z, "koshizuka_oka_1996")
    mT, mZ = ref.surge_front("martin_moyce_1952")
    kT, kZ = ref.surge_front("koshizuka_oka_1996")
    shown = mT <= 3.5  # the data go on to T = 9: the plot shows the range compared
    mT, mZ = mT[shown], mZ[shown]
    worst = float(np.abs(err).max())
    detail = (f"{sim.fluid.n} fluid particles; release delay dT = {delay:.3f} (Martin & Moyce); "
              f"with no delay {np.abs(err0).max():.1%}; Koshizuka & Oka: dT = {k_delay:.3f}, "
              f"largest error {np.abs(k_err).max():.1%}")
    return Result(f"Dam break surge front, {label}",
                  "largest abs(Z / Z_ref - 1) over the Martin & Moyce points, T <= 3, after the fitted release delay",
                  "Martin & Moyce (1952); Koshizuka & Oka (1996) shown", worst, 0.05, bool(worst < 0.05), detail,
                  [("SPH", T, Z, "sim"), (f"SPH, released dT = {delay:.2f} later", T + delay, Z, "sim"),
                   ("Martin & Moyce 1952", mT, mZ, "data"), ("Koshizuka & Oka 1996", kT, kZ, "data")],
                  ("T = t sqrt(2g/a)", "Z = z/a"))


def dam_break_classic(quick):
    """The shipped ``dam_break_2d`` (a = 1 m, 100 particles across, water's viscosity)."""
    return _dam_break("classic", "dam_break_2d", [("output.vtk", False)], 1.0)


#: a column a = 0.25 m, 50 particles across, with the model of the shipped ``dam_break_2d_bi``
#: (consistent walls, Fourtakas diffusion, water's viscosity, inelastic bounce)
DAM_BREAK_BI = {"dim": 2, "dp": 0.005, "fluid": [{"min": [0.0, 0.0], "max": [0.25, 0.5]}],
                "tank": {"min": [0.0, 0.0], "max": [1.0, 0.75], "open_top": True}, "time": {"end": 1.0},
                "model": {"name": "bi", "BCType": "BIConsistent_numeric", "DiffusiveTerm": "FourtakasDiffusiveTerm",
                          "ViscousTerm": "PhysicalViscosity_MGVT", "EOS": "LinearizedColeEquationOfState",
                          "elasticBounce": "epsilon", "elasticFactor": 0.0},
                "parameters": {"dynamicViscosity": 1.0e-3, "delta": 0.1}, "output": {"vtk": False}}


def dam_break_bi(quick):
    return _dam_break("WCSPH-BI", DAM_BREAK_BI, [], 0.25)


def _spheric2(label, quick, overrides=()):
    """SPHERIC test 2 (``spheric2_3d``) against Kleefsman et al. (2005): the arrival times and
    the means of the sensors and gauges over 0.5-1.5 s (``spheric2``). The full set runs at
    dp = 0.025 (43 k fluid particles), where every figure must meet its tolerance; the quick
    set at dp = 0.05 (5 k, three particles over the box's height), where only the reservoir
    level and the impact are asked to be within twice their tolerance."""
    import tempfile

    from . import spheric2

    dp = 0.05 if quick else 0.025
    sim = _sim("spheric2_3d", [("dp", dp), ("output.vtk", False), ("output.progress", False)] + list(overrides))
    with tempfile.TemporaryDirectory() as tmp:
        sim.run(tmp, progress=False)
        run = spheric2.probes_series(Path(tmp) / "probes.csv")
    rows = spheric2.compare(spheric2.figures(run))
    lead = spheric2.reservoir_lead(run)
    if quick:
        judged = [r for r in rows if r[0] in ("P1 impact", "H4 mean")]
        passed = all(abs(r[3]) <= 2 * r[4] for r in judged)
    else:
        judged = [r for r in rows if r[0] not in spheric2.SHOWN_ONLY]
        passed = all(r[5] for r in judged)
    worst = max(abs(r[3]) / r[4] for r in judged)
    detail = (f"dp = {sim.dp:g} m, {sim.n_fluid()} fluid particles. Error: absolute for times [s] and levels [m], "
              "relative for pressures.\n\n| figure | experiment | run | error | tolerance |\n|---|---|---|---|---|\n"
              + "\n".join(f"| {n} | {e:.4g} | {r:.4g} | {err:+.3g} | {tol:g}{'' if n not in spheric2.SHOWN_ONLY else ' (shown)'} |"
                          for n, e, r, err, tol, _ in rows)
              + f"\n\nThe experiment's reservoir (H4) drains {1e3 * lead:.0f} ms ahead of the run's over "
              f"{spheric2.LEAD_WINDOW[0]:g}-{spheric2.LEAD_WINDOW[1]:g} s, before the flood reaches a gauge or the box "
              "(shown, not judged: the experiment's clock against a release at t = 0; docs/accuracy.md §2h). "
              "On the reservoir's clock (the record's times plus that lead) the arrivals' errors are "
              + ", ".join(f"{n} {err - lead:+.3f} s" for n, _, _, err, _, _ in rows if n in spheric2.ARRIVALS) + ".")
    exp = spheric2.experiment()
    curves = []
    end = float(run["P1"][0][-1])
    for name in ("P1", "P3"):
        te, pe = exp[name]
        curves += [(f"{name} run", *run[name], "sim"), (f"{name} Kleefsman et al.", te[te <= end], pe[te <= end], "ref")]
    return Result(f"SPHERIC 2, 3D dam break on a box, {label}",
                  "largest error / tolerance over the arrival times and 0.5-1.5 s means" + (" (quick: P1 impact, H4)" if quick else ""),
                  "Kleefsman et al. (2005)", worst, 2.0 if quick else 1.0, passed, detail, curves, ("t [s]", "p [Pa]"))


def spheric2_bi(quick):
    return _spheric2("WCSPH-BI", quick)


def spheric2_classic(quick):
    return _spheric2("classic", quick, SPHERIC2_CLASSIC)


def moving_square(quick, overrides=(), case="moving_square_2d", label="WCSPH-BI"):
    """SPHERIC test 6 (``moving_square_2d``, Re = 100) at 40 particles across the square (the
    case ships 20 for a quick look: its mean is 7-8 % low there): the drag coefficient
    C_D = -2 F_x / (rho U^2 L) against the reference, its mean over 2 <= t <= 6 s (within 5 %)
    and the RMS of the difference (at most 0.15)."""
    import csv
    import tempfile

    sim = _sim(case, [("dp", 0.025), ("time.end", 6.0), ("output.vtk", False),
                      ("output.progress", False)] + list(overrides))
    with tempfile.TemporaryDirectory() as tmp:
        sim.run(tmp, progress=False)
        with open(Path(tmp) / "probes.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    t = np.array([float(r["time"]) for r in rows])
    cd = -2.0 * np.array([float(r["square_fx"]) for r in rows])
    rt, rcd = ref.moving_square_drag()
    sel = (t >= 2.0) & (t <= 6.0)
    mean, mean_ref = float(np.mean(cd[sel])), float(np.mean(rcd[(rt >= 2.0) & (rt <= 6.0)]))
    rms = float(np.sqrt(np.mean((cd[sel] - np.interp(t[sel], rt, rcd)) ** 2)))
    err = abs(mean / mean_ref - 1)
    return Result(f"SPHERIC 6, moving square, drag, {label}", "abs(mean C_D / reference - 1) over 2 <= t <= 6 s; RMS of the difference",
                  "SPHERIC test 6 reference, Re = 100", err, 0.05, bool(err < 0.05 and rms <= 0.15),
                  f"mean C_D {mean:.3f} against {mean_ref:.3f}; RMS of C_D - C_D,ref {rms:.3f} (at most 0.15); "
                  f"{sim.n_fluid()} fluid particles",
                  [("SPH", t, cd, "sim"), ("reference", rt, rcd, "ref")], ("t [s]", "C_D"))


def moving_square_classic(quick):
    """SPHERIC 6 in the classic model (``moving_square_2d_classic``: the square and the box
    walled with particles, the body's load the reaction of the wall terms on the fluid)."""
    return moving_square(quick, case="moving_square_2d_classic", label="classic")


def floating_box(quick):
    """``floating_box_2d``: a box of half water's density released after 1 s of settling;
    over the next 5 s its centre stays within dp/2 of the water level (Archimedes: half its
    height immersed) on average, and it drifts less than dp sideways."""
    import csv
    import tempfile

    sim = _sim("floating_box_2d", [("output.vtk", False), ("output.progress", False)])
    with tempfile.TemporaryDirectory() as tmp:
        sim.run(tmp, progress=False)
        with open(Path(tmp) / "probes.csv", newline="") as f:
            rows = [r for r in csv.DictReader(f) if float(r["time"]) >= 1.0]
    t = np.array([float(r["time"]) for r in rows])
    y, level, x = (np.array([float(r[k]) for r in rows]) for k in ("box_y", "level", "box_x"))
    draft = float(np.mean(y - level))  # the centre above the level: 0 at Archimedes' draft
    drift = float(np.abs(x - x[0]).max())
    dp = sim.dp
    err = max(abs(draft) / (0.5 * dp), drift / dp)
    return Result("Floating box at Archimedes' draft, WCSPH-BI", "largest of mean |centre - level| / (dp/2) and "
                  "the sideways drift / dp over 1-6 s", "Archimedes: the centre at the water level", err, 1.0,
                  bool(err < 1.0), f"mean centre - level {draft * 1e3:+.1f} mm, largest {np.abs(y - level).max() * 1e3:.1f} mm; "
                  f"drift {drift * 1e3:.1f} mm; dp = {dp * 1e3:g} mm",
                  [("centre - level", t, y - level, "sim"), ("Archimedes", t, 0 * t, "ref")], ("t [s]", "y_c - level [m]"))


def cylinder_entry(quick, case="cylinder_entry_2d", label="WCSPH-BI"):
    """A cylinder sinking into still water, ``cylinder_entry_2d`` (R = 1 m, relative density
    1.2, released at rest half immersed, R / dp = 20): its displacement against
    T = (t - release) sqrt(g/R) and the experiment of Moyo & Greenhow (2000) over its record
    (T = 0.5-7.8), the largest difference as a fraction of the experiment's final displacement
    within 5 %. The record's displacement is the body's fall since T = 0.5, where it starts
    (``references.moyo_greenhow_cylinder``), and the run's is taken from there too. The
    experiment's velocity, recorded from the release, is shown with the same measure
    against its largest speed. Fekken's (2004) figures for the case, which DualSPHysics ships
    beside the experiment and which this check scored until 2026-12-07, are a numerical
    model's (ComFLOW, a PhD thesis): they fall behind the experiment after T = 2.5, 0.69 of
    its displacement at T = 7.8, at a speed a steady fall would have with a drag coefficient
    of 3 where the experiment's is about 1 (docs/accuracy.md §5). Shown, from the release,
    over T <= 8."""
    import csv
    import tempfile

    sim = _sim(case, [("output.vtk", False), ("output.progress", False)])
    release = sim.case["polygon"][0]["floating"]["release"]
    with tempfile.TemporaryDirectory() as tmp:
        sim.run(tmp, progress=False)
        with open(Path(tmp) / "probes.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    R, g = 1.0, 9.81
    t = np.array([float(r["time"]) for r in rows])
    y = np.array([float(r["cylinder_y"]) for r in rows])
    vy = np.array([float(r["cylinder_vy"]) for r in rows])
    T = (t - release) * np.sqrt(g / R)
    keep = (T >= 0) & (T <= 8.0)
    T, d, V = T[keep], y[keep] - y[keep][0], vy[keep] / math.sqrt(g * R)
    eT, ed = ref.moyo_greenhow_cylinder()
    d_rec = d - np.interp(eT[0], T, d)  # the fall since the record's start, as it counts it
    seen = (T >= eT[0]) & (T <= eT[-1])
    err = float(np.max(np.abs(d_rec[seen] - np.interp(T[seen], eT, ed))) / abs(ed[-1]))
    vT, vV = ref.moyo_greenhow_cylinder_velocity()
    v_seen = T <= vT[-1]
    err_v = float(np.max(np.abs(V[v_seen] - np.interp(T[v_seen], vT, vV))) / np.max(np.abs(vV)))
    fT, fd = ref.fekken_cylinder()
    err_num = float(np.max(np.abs(d - np.interp(T, fT, fd))) / abs(fd[-1]))
    return Result(f"Cylinder entry (Moyo & Greenhow 2000), {label}",
                  f"largest |displacement - experiment| / its final displacement, {eT[0]:g} <= T <= {eT[-1]:g} "
                  f"(the fall since T = {eT[0]:g}, as the record counts it)",
                  "Moyo & Greenhow (2000), as in DualSPHysics' CaseFloatingSphereVal2D", err, 0.05, bool(err < 0.05),
                  f"displacement at T = {eT[-1]:g}: {np.interp(eT[-1], T, d_rec):.3f} m against {ed[-1]:.3f} m; "
                  f"R / dp = {R / sim.dp:g}. Velocity (shown): largest |V - experiment| {err_v:.1%} of its largest "
                  f"speed over T <= {vT[-1]:g}, V = {np.interp(vT[-1], T, V):.3f} against {vV[-1]:.3f} at the end. "
                  f"Against Fekken's (2004) numerical figures (from the release, T <= 8): largest difference "
                  f"{err_num:.1%} of their final displacement, {np.interp(8.0, T, d):.3f} m against {fd[-1]:.3f} m "
                  "at T = 8",
                  [("SPH", T[T >= eT[0]], d_rec[T >= eT[0]], "sim"), ("Moyo & Greenhow 2000 (experiment)", eT, ed, "ref"),
                   ("Fekken 2004 (numerical)", fT[fT >= eT[0]], fd[fT >= eT[0]] - np.interp(eT[0], fT, fd), "other")],
                  ("T = t sqrt(g/R)", f"fall since T = {eT[0]:g} [m]"))


def _classic_cylinder():
    """``cylinder_entry_2d`` in the classic model: its wall particles sampled from the polygon
    in rows along its outline, the case's own viscosity (water's, here in Morris' form), no
    XSPH, the walls no-slip by Adami's extrapolated velocity (as the classic channels need: a
    viscous fluid sticks to the body). XSPH on the momentum, which the classic 2D dam break
    keeps at epsilon = 0.01 for its far wall's impact, is a viscosity thousands of times
    water's that damps a moving body (docs/accuracy.md §4b): with it the fall was 6.0 % short
    of the experiment, at 0.005 4.6 %, at 0.0025 3.9 % and without it 3.5 % (measured from
    the release, 2026-12-07; docs/accuracy.md §5). The column is sampled compressed to its
    hydrostatic density (``geometry.compressed_lattice``), so the water stands at the
    cylinder's centre at the release, 0.5 s, as in the WCSPH-BI case (on a plain lattice it
    settled 0.13 m lower). Until 2026-12-07 it ran the artificial viscosity alpha = 0.02 the
    WCSPH-BI case then had, scored against Fekken's numerical figures."""
    from ..case.config import read_toml, resolve

    data = read_toml(resolve("cylinder_entry_2d"))
    data["model"] = {"name": "classic", "kernel": "wendland", "smoothing_ratio": 2.0, "xsph": "None",
                     "ViscousTerm": "PhysicalViscosity_MVT", "dynamicViscosity": data["model"]["dynamicViscosity"],
                     "wall_velocity": "adami"}
    return data


def cylinder_entry_classic(quick):
    return cylinder_entry(quick, _classic_cylinder(), "classic")


def oscillating_cylinder(quick, case="oscillating_cylinder_2d", label="WCSPH-BI"):
    """``oscillating_cylinder_2d`` (R / dp = 20): the fluid's force along x on a cylinder
    oscillated along x in a closed tank of still water, fitted over the periods after the
    ramp as F = -m_a a - c v + F_0. The added mass m_a within 5 % of potential flow's for the
    case's own cylinder and tank (``potential.added_mass_2d``), and the force in phase with
    the velocity, c / (m_a omega), under 5 % of the inertial one (at KC = 0.31 and Re = 6e5
    potential flow has none and the viscous boundary layer about 0.1 %)."""
    import csv
    import tempfile

    from ..boundaries.motion import Motion
    from .potential import added_mass_2d

    sim = _sim(case, [("output.vtk", False), ("output.progress", False)])
    body = sim.case["polygon"][0]
    m = body["motion"]
    motion, w = Motion(m, 2), 2 * math.pi * m["frequency"]
    tank = sim.case["tank"]
    (x0, y0), (x1, y1) = tank["min"], tank["max"]
    rho = sim.case["physics"]["rho0"]
    m_ref = added_mass_2d(body["points"], [(x0, y0), (x1, y0), (x1, y1), (x0, y1)], rho=rho)[0]
    with tempfile.TemporaryDirectory() as tmp:
        sim.run(tmp, progress=False)
        with open(Path(tmp) / "probes.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    t = np.array([float(r["time"]) for r in rows])
    fx = np.array([float(r[f"{body['name']}_fx"]) for r in rows])
    vel = np.array([motion.state(tt)[2][0] for tt in t])  # the body's own motion, as its walls follow it
    acc = np.array([motion.acceleration(tt)[0][0] for tt in t])
    keep = t >= max(m["ramp"], 0.0) + 0.25 * 2 * math.pi / w
    (m_a, c, f0), *_ = np.linalg.lstsq(np.c_[-acc[keep], -vel[keep], np.ones(keep.sum())], fx[keep], rcond=None)
    e_m, zeta = m_a / m_ref - 1, c / (m_a * w)
    err = max(abs(e_m) / 0.05, abs(zeta) / 0.05)
    inertia = -m_ref * acc
    return Result(f"Oscillating cylinder, added mass, {label}", "abs(m_a / potential flow - 1) / 5 % and "
                  "abs(c / (m_a omega)) / 5 %, F_x = -m_a a - c v + F_0 fitted after the ramp",
                  "potential flow in the tank (source panels)", err, 1.0, bool(err < 1.0),
                  f"m_a = {m_a:.1f} kg/m against {m_ref:.1f} ({e_m:+.1%}; rho pi R^2 = {rho * math.pi:.1f}); "
                  f"c = {c:.1f} N s/m, c / (m_a omega) = {zeta:+.3f}; F_0 = {f0:.1f} N; R / dp = {1.0 / sim.dp:g}",
                  [("SPH", t, fx, "sim"), ("potential flow, -m_a a", t, inertia, "ref")], ("t [s]", "F_x [N/m]"))


def _classic_oscillating_cylinder():
    """``oscillating_cylinder_2d`` in the classic model's walls: wall particles sampled from
    the polygon with Adami's wall pressure, water's viscosity (Morris), the continuity
    density with Fourtakas' diffusion and the case's ambient pressure in the Cole EOS, no
    XSPH. The summation density with XSPH (epsilon = 0.01, the classic 3D check's) loads the
    body right (added mass -0.7 % at R / dp = 20) but damps it by XSPH's viscosity, a force
    in phase with the velocity 19 % of the inertial one (docs/accuracy.md §4b); without XSPH
    a summation density does not hold the closed tank together."""
    from ..case.config import read_toml, resolve

    data = read_toml(resolve("oscillating_cylinder_2d"))
    data["model"] = {"name": "classic", "kernel": "wendland", "smoothing_ratio": 2.0, "xsph": "None",
                     "density": "continuity", "DiffusiveTerm": "FourtakasDiffusiveTerm", "EOS": "ColeEquationOfState",
                     "ViscousTerm": "PhysicalViscosity_MVT", "dynamicViscosity": 1.0e-3}
    return data


def oscillating_cylinder_classic(quick):
    return oscillating_cylinder(quick, _classic_oscillating_cylinder(), "classic")


def wave_flume(quick, overrides=()):
    """``wave_flume_2d``: a piston makes regular waves (linear theory: H = 0.06 m, T = 1.2 s,
    h = 0.4 m); at gauges 2, 3 and 4 wavelengths from it, over the last 8 s, the mean
    zero-crossing height within 5 % of H and the period within 1 % of T; the reflection
    coefficient of the far end (damping zone) from two gauges a quarter wavelength apart
    (Goda & Suzuki 1976) below 10 %."""
    import csv
    import tempfile

    from ..boundaries.motion import wave_number
    from .waves import goda_suzuki, zero_crossing

    sim = _sim("wave_flume_2d", [("output.vtk", False), ("output.progress", False)] + list(overrides))
    m = sim.case["obstacle"][0]["motion"]
    H, T, h = m["height"], m["period"], m["depth"]
    with tempfile.TemporaryDirectory() as tmp:
        sim.run(tmp, progress=False)
        with open(Path(tmp) / "probes.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    t = np.array([float(r["time"]) for r in rows])
    g = {name: np.array([float(r[name]) for r in rows]) for name in ("G2", "G3", "G4", "G3b")}
    win = t >= t[-1] - 8.0
    figures = {name: zero_crossing(t[win], g[name][win]) for name in ("G2", "G3", "G4")}
    k = wave_number(2 * math.pi / T, h, 9.81)
    a_i, a_r = goda_suzuki(t[win], g["G3"][win], g["G3b"][win], T, 0.25 * 2 * math.pi / k, k)
    kr = a_r / a_i
    e_h = max(abs(hh / H - 1) for hh, _ in figures.values())
    e_t = max(abs(tt / T - 1) for _, tt in figures.values())
    err = max(e_h / 0.05, e_t / 0.01, kr / 0.10)
    detail = ("| gauge | height [m] | vs H | period [s] | vs T |\n|---|---|---|---|---|\n"
              + "\n".join(f"| {n} | {hh:.4f} | {hh / H - 1:+.1%} | {tt:.4f} | {tt / T - 1:+.2%} |" for n, (hh, tt) in figures.items())
              + f"\n\nreflection coefficient (G3, G3b) {kr:.3f}; incident amplitude {a_i:.4f} m; dp = {sim.dp:g} m")
    return Result("Wave flume, piston, regular waves, WCSPH-BI", "largest of height error / 5 %, period error / 1 % "
                  "(gauges 2-4 wavelengths out) and reflection / 10 %", "linear wavemaker theory (Biesel)", err, 1.0,
                  bool(err < 1.0), detail, [(n, t, g[n], "sim") for n in ("G2", "G4")], ("t [s]", "level [m]"))


#: CIEM gauges: the whole waves compared (1 s each, the piston's period), after the ramp
#: (the stroke is steady from 2 s) and once the wave train has reached the gauge; before the
#: experiment's structure, 2.97 m beyond the piston and not modelled, reflects into them
CIEM_WAVES = {"WG1": (2.0, 3.0, 4.0, 5.0), "WG2": (4.0, 5.0)}


def ciem_figures(t, levels):
    """The CIEM comparison of a run's gauges (``levels``: name -> level [m] at times ``t``,
    still until the piston starts at 0.925 s) with the record: rows (gauge, wave, run's height,
    record's height, relative difference) for each whole wave of ``CIEM_WAVES``, and per gauge
    the lag [s] of the run's waves behind the record's (the shift that best matches the two
    series over the compared waves; positive: the run's come late), and the run's elevations."""
    t_ref, _, ref_eta = ref.ciem_wavemaker()
    rows, lags, etas = [], {}, {}
    for name, starts in CIEM_WAVES.items():
        eta = etas[name] = levels[name] - levels[name][t < 0.9].mean()
        for a in starts:
            keep = (t_ref >= a) & (t_ref < a + 1.0)
            h_run, h_ref = float(np.ptp(np.interp(t_ref[keep], t, eta))), float(np.ptp(ref_eta[name][keep]))
            rows.append((name, a, h_run, h_ref, h_run / h_ref - 1))
        fine = np.arange(starts[0], starts[-1] + 1.0, 0.001)
        e = np.interp(fine, t_ref, ref_eta[name])
        shifts = np.arange(-250, 251)  # ms
        match = [np.dot(np.interp(fine + 0.001 * L, t, eta), e) for L in shifts]
        lags[name] = 0.001 * float(shifts[int(np.argmax(match))])
    return rows, lags, etas


def ciem_wavemaker(quick, overrides=()):
    """``ciem_wavemaker_2d``: the CIEM flume's piston driven by its recorded stroke (regular
    waves, T = 1 s, about 7 cm, in 0.31 m of water) against the measured elevation at WG1 and
    WG2 (0.35 and 1.80 m from the piston): each whole wave's crest-to-trough height within
    10 % of the measured one (the record's 1 mm steps are 1.4 % of it; its stroke, in 1 mm
    steps too, drives the piston; the depth is known to a few mm from the public case), and
    the waves' travel from WG1 to WG2 (the difference of the two gauges' lags behind the
    record) within 0.02 s, 2 % of the 1.06 s it takes. The lag itself is shown: at both
    gauges the record's waves come about 0.06 s after those linear theory makes of the
    recorded stroke (the run's within 0.01 s of linear theory), the same at 0.35 and 1.80 m,
    so an offset between the stroke's record and the gauges', not the waves' speed."""
    import csv
    import tempfile

    sim = _sim("ciem_wavemaker_2d", [("output.vtk", False), ("output.progress", False)] + list(overrides))
    with tempfile.TemporaryDirectory() as tmp:
        sim.run(tmp, progress=False)
        with open(Path(tmp) / "probes.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    t = np.array([float(r["time"]) for r in rows])
    levels = {name: np.array([float(r[name]) for r in rows]) for name in CIEM_WAVES}
    waves, lags, etas = ciem_figures(t, levels)
    travel = lags["WG2"] - lags["WG1"]
    err = max(max(abs(w[4]) for w in waves) / 0.10, abs(travel) / 0.02)
    detail = ("| gauge | wave | run's height [m] | record's [m] | difference |\n|---|---|---|---|---|\n"
              + "\n".join(f"| {n} | {a:g}-{a + 1:g} s | {hr:.4f} | {hx:.4f} | {e:+.1%} |" for n, a, hr, hx, e in waves)
              + f"\n\nlag of the run's waves behind the record's: WG1 {lags['WG1']:+.3f} s, WG2 {lags['WG2']:+.3f} s; "
              f"travel WG1 -> WG2 {travel:+.3f} s against the record's; dp = {sim.dp:g} m")
    t_ref, _, ref_eta = ref.ciem_wavemaker()
    curves = []
    for name in CIEM_WAVES:
        curves += [(f"{name} SPH", t, etas[name], "sim"), (f"{name} CIEM", t_ref, ref_eta[name], "ref")]
    return Result("Wave flume, CIEM record (piston, T = 1 s), WCSPH-BI", "largest of height error / 10 % (each "
                  "whole wave at WG1, WG2) and the travel time WG1 -> WG2 against the record's / 0.02 s",
                  "CIEM flume measurements (as DualSPHysics ships them)", err, 1.0, bool(err < 1.0), detail, curves,
                  ("t [s]", "elevation [m]"))


#: the resolution of the Lobovsky check: H / dp = 150
LOBOVSKY_DP = 0.002


def lobovsky(quick, overrides=(), label="WCSPH-BI"):
    """Lobovsky et al. (2014), ``dam_break_2d_bi`` at dp = 0.002 (H = 0.3 m, 150 spacings; TNL-SPH's
    example of this case uses the same): the mean wall pressure of sensors P1-P3 over
    T = t sqrt(g/H) in [3, 5] (after the impact, the run-up and its fall) within 15 % of the
    experiment's; the peak at P1 and the levels h/H at gauges H1-H4 over the same window are
    shown. The means converge from above as dp shrinks
    (docs/accuracy.md: the worst of the three +24 % at the case's dp = 0.005, +9 % at 0.002)."""
    import csv
    import tempfile

    H, g = 0.3, 9.81
    sim = _sim("dam_break_2d_bi", [("dp", LOBOVSKY_DP), ("time.end", 5.2 / math.sqrt(g / H)), ("output.vtk", False),
                                   ("output.progress", False), ("output.probe_interval", 0.002)] + list(overrides))
    with tempfile.TemporaryDirectory() as tmp:
        sim.run(tmp, progress=False)
        with open(Path(tmp) / "probes.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    T = np.array([float(r["time"]) for r in rows]) * math.sqrt(g / H)
    scale = float(sim.rho0) * g * H
    errs, lines, curves = [], [], []
    for k in (1, 2, 3):
        p = np.array([float(r[f"P{k}"]) for r in rows]) / scale
        rT, rp = ref.lobovsky_pressure(k)
        m, mr = float(np.mean(p[(T >= 3) & (T <= 5)])), float(np.mean(rp[(rT >= 3) & (rT <= 5)]))
        errs.append(m / mr - 1)
        lines.append(f"P{k}: {m:.3f} against {mr:.3f} ({m / mr - 1:+.1%}), peak {p.max():.2f} against {rp.max():.2f}")
        curves += [(f"P{k}", T, p, "sim"), (f"P{k} Lobovsky et al.", rT, rp, "ref")]
    levels = []
    for k in (1, 2, 3, 4):  # shown, not scored: the levels over the same window
        h = np.array([float(r[f"H{k}"]) for r in rows]) / H
        rT, rh = ref.lobovsky_level(k)
        m, mr = float(np.mean(h[(T >= 3) & (T <= 5)])), float(np.mean(rh[(rT >= 3) & (rT <= 5)]))
        levels.append(f"H{k} {m:.3f} against {mr:.3f}")
    worst = float(np.max(np.abs(errs)))
    return Result(f"Lobovsky et al. (2014) wall pressure, {label}", "largest abs(mean p / reference - 1), P1-P3, 3 <= T <= 5",
                  "Lobovsky et al. (2014), H = 300 mm", worst, 0.15, worst < 0.15,
                  "; ".join(lines) + "; levels h/H over the same T (shown): " + ", ".join(levels)
                  + f"; {sim.n_fluid()} fluid particles", curves, ("T = t sqrt(g/H)", "p / (rho g H)"))


#: checks whose tolerance is a goal of the project not reached yet (docs/accuracy.md says by
#: how much and why): they run and report like the others, and ``test_full_validation_set``
#: expects exactly these to fail, so one that starts to pass must leave this set
OPEN_GOALS = {"spheric2_bi", "spheric2_classic", "moving_square_classic"}

#: (function, in the quick subset)
CHECKS = [
    (poiseuille, True),
    (couette, True),
    (poiseuille_classic, True),
    (couette_classic, True),
    (poiseuille_open, True),
    (taylor_green, True),
    (hydrostatic_classic, True),
    (hydrostatic_bi, True),
    (dam_break_classic, False),
    (dam_break_bi, False),
    (spheric2_bi, True),
    (spheric2_classic, False),
    (moving_square, False),
    (moving_square_classic, False),
    (lobovsky, False),
    (floating_box, False),
    (cylinder_entry, False),
    (cylinder_entry_classic, False),
    (oscillating_cylinder, False),
    (oscillating_cylinder_classic, False),
    (wave_flume, False),
    (ciem_wavemaker, False),
    (convergence_poiseuille, False),
    (convergence_taylor_green, False),
]


def run_all(output, quick=False, only=None, log=print):
    """Run the validation set (the quick subset with ``quick``; the checks whose function
    name contains ``only``, or the one named ``only`` where one is: ``couette`` is the
    WCSPH-BI Couette check alone, not ``couette_classic`` too), write ``report.md`` and the
    plots into ``output``; return the results."""
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    results = []
    exact = only is not None and any(fn.__name__ == only for fn, _ in CHECKS)
    for fn, in_quick in CHECKS:
        if (quick and not in_quick) or (only and (fn.__name__ != only if exact else only not in fn.__name__)):
            continue
        t0 = time.perf_counter()
        log(f"validate: {fn.__name__} ...")
        try:
            r = fn(quick)
        except (CaseError, SimulationError) as e:  # a failed check, reported as one
            r = Result(fn.__name__, "(the run stopped)", "", float("nan"), 0.0, False, str(e))
        r.seconds = time.perf_counter() - t0
        r.check = fn.__name__
        log(f"validate: {fn.__name__}: {'pass' if r.passed else 'FAIL'} ({r.measured:.4g}, "
            f"tolerance {r.tolerance:g}) in {r.seconds:.0f} s")
        results.append(r)
    write_report(out, results, quick)
    return results


def write_report(out, results, quick):
    from ..io.vtk import write_text

    plots = _plots(out, results)
    open_goals = [r.name for r in results if r.check in OPEN_GOALS]
    lines = ["# wcsph validation report", "",
             f"{'Quick subset' if quick else 'Full set'}: {sum(r.passed for r in results)} of {len(results)} "
             "checks pass." + (f" Open goals (tolerances not reached yet, see docs/accuracy.md): {', '.join(open_goals)}."
                               if open_goals else ""), "",
             "| check | compared | reference | measured | tolerance | result | time |",
             "|---|---|---|---|---|---|---|"]
    for r in results:
        limit = f"< {r.tolerance:g}" if "order" not in r.what else f">= {r.tolerance:g}"
        lines.append(f"| {r.name} | {r.what} | {r.reference} | {r.measured:.4g} | {limit} | "
                     f"{'pass' if r.passed else '**FAIL**'} | {r.seconds:.0f} s |")
    for r, png in zip(results, plots):
        lines += ["", f"## {r.name}", "", r.detail]
        if png:
            lines += ["", f"![{r.name}]({png})"]
    write_text(out / "report.md", "\n".join(lines) + "\n")


def _plots(out, results):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io.vtk import atomic

    names = []
    for k, r in enumerate(results):
        fig, ax = plt.subplots(figsize=(6, 4))
        for label, x, y, kind in r.curves:
            style = {"sim": dict(marker=".", ls="none", ms=3), "ref": dict(color="k", lw=1),
                     "other": dict(color="0.5", lw=1, ls="--"),  # a second reference, shown, not scored
                     "data": dict(marker="o", ls="none", mfc="none")}[kind]
            ax.plot(x, y, label=label, **style)
        if r.name.startswith("Convergence"):
            ax.set_xscale("log")
            ax.set_yscale("log")
        ax.set_xlabel(r.axes[0])
        ax.set_ylabel(r.axes[1])
        ax.set_title(r.name, fontsize=10)
        ax.legend(fontsize=7)
        fig.tight_layout()
        name = f"check_{k:02d}.png"
        with atomic(out / name) as tmp:
            fig.savefig(tmp, dpi=90, format="png")
        plt.close(fig)
        names.append(name)
    return names
