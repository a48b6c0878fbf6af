"""The viscosity each dissipative term amounts to, measured in a 3D periodic shear flow.

A triply periodic cube of fluid at rest in pressure, lattice spacing dp, with the shear wave
v_x = U sin(k z): one derivative evaluation gives Dv_x/Dt, and a term whose continuum limit is
nu Lap v gives Dv_x/Dt = -nu k^2 v_x, so nu_eff = -sum(a_x sin) / (k^2 U sum(sin^2)). The
time step is the case's own (XSPH on the momentum is epsilon/dt times a smoothing, so its
viscosity depends on dt). Defaults: the SPHERIC 2 set-up at dp = 0.025 (h = 2 dp, c0 =
10 sqrt(g 0.55) = 23.2 m/s); water is nu = 1e-6 m^2/s.

    python validation/dissipation.py [--dp 0.025] [--c0 23.2]
"""
import argparse
import math

import numpy as np

import wcsph
from wcsph.case.config import validate

#: (label, [model] table) of the terms compared; each alone, no diffusive term
TERMS = [
    ("BI: artificial viscosity alpha = 0.1", {"name": "bi", "DiffusiveTerm": "None", "ViscousTerm": "ArtificialViscosity", "alpha": 0.1}),
    ("BI: artificial viscosity alpha = 0.02 (spec default)", {"name": "bi", "DiffusiveTerm": "None", "ViscousTerm": "ArtificialViscosity", "alpha": 0.02}),
    ("BI: MGVT, mu = 1e-3 Pa s (water)", {"name": "bi", "DiffusiveTerm": "None", "ViscousTerm": "PhysicalViscosity_MGVT", "dynamicViscosity": 1e-3}),
    ("BI: MVT, mu = 1e-3 Pa s (water)", {"name": "bi", "DiffusiveTerm": "None", "ViscousTerm": "PhysicalViscosity_MVT", "dynamicViscosity": 1e-3}),
    ("classic: XSPH on the momentum, epsilon = 0.1", {"name": "classic", "xsph": "momentum", "xsph_epsilon": 0.1}),
    ("classic: XSPH on the momentum, epsilon = 0.01", {"name": "classic", "xsph": "momentum", "xsph_epsilon": 0.01}),
    ("classic: MVT, mu = 1e-3 Pa s, no XSPH", {"name": "classic", "xsph": "None", "ViscousTerm": "PhysicalViscosity_MVT", "dynamicViscosity": 1e-3}),
]


def effective_viscosity(model, dp, c0, n=16, U=0.1):
    L = n * dp
    k = 2 * math.pi / L
    case = {"dim": 3, "dp": dp, "precision": "float64",
            "fluid": [{"min": [0.0, 0.0, 0.0], "max": [L, L, L], "velocity": [f"{U}*sin({k}*z)", "0", "0"]}],
            "domain": {"min": [0.0, 0.0, 0.0], "max": [L, L, L], "periodic": [True, True, True]},
            "physics": {"rho0": 1000.0, "gravity": [0.0, 0.0, 0.0], "speed_of_sound": c0},
            "model": dict(model), "time": {"end": 1.0}, "output": {"vtk": False, "progress": False}}
    sim = wcsph.Simulation(validate(case, "<dissipation>"))
    dt = sim.time_step()
    sim.evaluate(sim.params_for(dt))
    x, a = (q.astype(float) for q in sim.host(sim.fluid, "x", "dvdt"))
    s = np.sin(k * x[2])
    return -float(np.sum(a[0] * s)) / (k * k * U * float(np.sum(s * s))), dt


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dp", type=float, default=0.025)
    ap.add_argument("--c0", type=float, default=23.2)
    args = ap.parse_args()
    print(f"dp = {args.dp:g} m, h = 2 dp, c0 = {args.c0:g} m/s; water nu = 1e-6 m^2/s\n")
    print("| term | nu_eff [m^2/s] | / water | dt [s] |\n|---|---|---|---|")
    for label, model in TERMS:
        nu, dt = effective_viscosity(model, args.dp, args.c0)
        print(f"| {label} | {nu:.3g} | {nu / 1e-6:.3g} | {dt:.3g} |")


if __name__ == "__main__":
    main()
