"""The references the validation set compares against: published measurements shipped in
``data/`` (with their sources in ``data/README.md``) and analytic solutions."""
import csv
from pathlib import Path

import numpy as np

DATA = Path(__file__).parent / "data"


def surge_front(name="martin_moyce_1952"):
    """(T, Z) of a dam-break surge-front data set in ``data/`` (Martin & Moyce 1952 or
    Koshizuka & Oka 1996), sorted by T."""
    with open(DATA / f"{name}_surge_front.csv") as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    ref = np.array(sorted((float(r["T"]), float(r["Z"])) for r in rows))
    return ref[:, 0], ref[:, 1]


#: the largest release delay a surge-front comparison may take, in T = t sqrt(2g/a): an
#: experiment's time origin is the gate's or diaphragm's release, which lets the water go
#: later than a simulation's instant release (docs/accuracy.md, "Surge fronts")
MAX_RELEASE_DELAY = 0.4


def surge_front_error(T, Z, name="martin_moyce_1952", t_max=3.0, max_delay=MAX_RELEASE_DELAY):
    """The simulated front (T, Z) against a data set: (delay, T_ref, Z/Z_ref - 1) with the
    data's T taken ``delay`` later than the simulation's, the delay in [0, max_delay] (steps
    of 0.005) that makes the largest error smallest, at the points with 0 < T <= t_max. A
    delay only holds the simulated front back: a front slower than the data is not helped,
    and max_delay = 0 compares with no delay at all."""
    rT, rZ = surge_front(name)
    keep = (rT > 0) & (rT <= t_max)
    rT, rZ = rT[keep], rZ[keep]
    best = None
    for delay in np.arange(0.0, max_delay + 1e-9, 0.005):
        err = np.interp(rT - delay, T, Z) / rZ - 1
        if best is None or np.abs(err).max() < np.abs(best[2]).max() - 1e-12:
            best = (float(delay), rT, err)
    return best


def poiseuille(y, t, L, F, nu, terms=100):
    """Body-force driven plane Poiseuille flow between plates y = 0 and y = L started from
    rest, the series solution of Morris, Fox & Zhu (1997), eq. 21:
    u = F/(2 nu) y (L - y) - sum_n 4 F L^2/(nu pi^3 (2n+1)^3) sin(pi y (2n+1)/L)
    exp(-(2n+1)^2 pi^2 nu t / L^2)."""
    y = np.asarray(y, dtype=float)
    u = F / (2 * nu) * y * (L - y)
    for n in range(terms):
        k = 2 * n + 1
        u -= 4 * F * L**2 / (nu * np.pi**3 * k**3) * np.sin(np.pi * y * k / L) * np.exp(-k**2 * np.pi**2 * nu * t / L**2)
    return u


def couette(y, t, L, U, nu, terms=400):
    """Plane Couette flow started by the plate y = L moving at U (the plate y = 0 at rest),
    Morris, Fox & Zhu (1997), eq. 22:
    u = U y/L + sum_n 2U/(n pi) (-1)^n sin(n pi y/L) exp(-nu n^2 pi^2 t/L^2)."""
    y = np.asarray(y, dtype=float)
    u = U * y / L
    for n in range(1, terms):
        u += 2 * U / (n * np.pi) * (-1) ** n * np.sin(n * np.pi * y / L) * np.exp(-nu * n**2 * np.pi**2 * t / L**2)
    return u


def couette_wall_shear(t, L, U, mu, nu, terms=400):
    """The shear stress on the moving plate y = L of ``couette``'s flow, mu du/dy there:
    mu U/L (1 + 2 sum_n exp(-nu n^2 pi^2 t/L^2)) (Stokes' first problem while it is young)."""
    n = np.arange(1, terms)
    return mu * U / L * (1 + 2 * np.sum(np.exp(-nu * n**2 * np.pi**2 * t / L**2)))


def taylor_green_decay_rate(re):
    """d ln(E_k)/dt of the Taylor-Green vortex on the unit square (U = 1): -16 pi^2 / Re."""
    return -16 * np.pi**2 / re


def taylor_green_velocity(x, t, re):
    """The Taylor-Green velocity (2, N) at points x on the unit square (U = 1):
    u = -e^{bt} cos(2 pi x) sin(2 pi y), v = e^{bt} sin(2 pi x) cos(2 pi y), b = -8 pi^2/Re."""
    e = np.exp(-8 * np.pi**2 / re * t)
    return np.stack([-e * np.cos(2 * np.pi * x[0]) * np.sin(2 * np.pi * x[1]),
                     e * np.sin(2 * np.pi * x[0]) * np.cos(2 * np.pi * x[1])])


def moving_square_drag():
    """(t, C_D) of SPHERIC test 6 at Re = 100, the reference drag coefficient of the square
    (pressure plus viscous parts, ``spheric6_moving_square_drag_re100.dat``)."""
    d = np.loadtxt(DATA / "spheric6_moving_square_drag_re100.dat", skiprows=2)
    return d[:, 0], d[:, 1] + d[:, 2]


def lobovsky_pressure(sensor):
    """(T, p / (rho g H)) of Lobovsky et al. (2014), H = 0.3 m, at sensor 1-4 on the wall
    the water hits (``lobovsky_2014_pressure_P{sensor}.dat``, the ensemble of their Fig. 18
    as TNL-SPH ships it), T = t sqrt(g/H)."""
    d = np.loadtxt(DATA / f"lobovsky_2014_pressure_P{sensor}.dat", comments="#")
    return d[:, 0], d[:, 1]


def lobovsky_level(gauge):
    """(T, h / H) of Lobovsky et al. (2014), H = 0.3 m, at level gauge 1-4 (x = 0.3, 0.865,
    1.114, 1.3625 m; ``lobovsky_2014_level_H{gauge}.dat``, their Fig. 16 as TNL-SPH ships
    it): the mean of the experiment's series there (two at H2-H4, one at H1), T = t sqrt(g/H)."""
    d = np.loadtxt(DATA / f"lobovsky_2014_level_H{gauge}.dat", comments="#")
    return d[:, 0], d[:, 1:].mean(axis=1)


def fekken_cylinder():
    """(T, displacement [m]) of Fekken's (2004) sinking cylinder, R = 1 m, T = t sqrt(g/R)."""
    d = np.loadtxt(DATA / "fekken_2004_cylinder_displacement.dat", comments="#")
    return d[:, 0], d[:, 1]


def moyo_greenhow_cylinder():
    """(T, displacement [m]) of Moyo & Greenhow's (2000) experiment on the case of
    ``fekken_cylinder`` (whose figures are a numerical model's), scaled to R = 1 m,
    T = t sqrt(g/R). The record starts at T = 0.5 and its displacement is taken from the
    body's place then, not at the release: the velocity record
    (``moyo_greenhow_cylinder_velocity``), which starts at the release, integrated from
    T = 0.5 gives it within 0.036 m over T <= 5 (0.11 m by T = 7.8, where the velocity read off
    the figure runs 2 % slow), while from T = 0 it is 0.056 m further down at once (the fall of
    the first half unit of T, which Fekken's figures have too)."""
    d = np.loadtxt(DATA / "moyo_greenhow_2000_cylinder_displacement.dat", comments="#")
    return d[:, 0], d[:, 1]


def moyo_greenhow_cylinder_velocity():
    """(T, V) of the same experiment: the cylinder's vertical velocity V = v / sqrt(g R)
    (R = 1 m) from its release at T = 0."""
    d = np.loadtxt(DATA / "moyo_greenhow_2000_cylinder_velocity.dat", comments="#")
    return d[:, 0], d[:, 1]


def ciem_wavemaker():
    """(t [s], piston [m], {gauge: elevation [m]}) of the CIEM flume's regular waves (scaled,
    T = 1 s), as DualSPHysics ships them with CaseWavemaker2D: WG1 and WG2 0.35 and 1.80 m from
    the piston's face (WG3, on the structure the case leaves out, is not returned)."""
    d = np.loadtxt(DATA / "ciem_wavemaker_2d_gauges.dat", comments="#")
    return d[:, 0], d[:, 1], {"WG1": d[:, 2], "WG2": d[:, 3]}
