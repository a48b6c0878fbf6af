"""Wall time to 1 s of simulated time of ``dam_break_2d_bi`` with each integrator at the
largest stable time step found, on this machine (the README table "Time integration").

    python benchmarks/integrators.py [--end 1.0] [--dp 0.005] [--schemes ...] [--out FILE]

For each scheme the CFL number is raised along a ladder until a run fails. A run counts as
stable when it reaches ``--end`` without blowing up (non-finite state, speed above c0) and
its kinetic energy at the end lies within 25 % of the reference run (symplectic Verlet at
cfl 0.25): a run that survives with a wrong flow is not stable. Wall time is the stepping
time (compilation excluded). The implicit midpoint is run with the spec's defaults and,
as ``midpoint_relaxed``, with relaxation w = 0.7 (up to 300 iterations, tolerance 1e-6).
"""
import argparse
import json
import time

import numpy as np

import wcsph
from wcsph.case.config import load

RELAXED = {"time.midpointRelaxCoef": 0.7, "time.midpointRelaxCoef_0": 0.7, "time.midpointMaxInterations": 300,
           "time.midpointResidualTolerance": 1e-6}
LADDERS = {
    "symplectic_euler": [(c, {}) for c in (0.025, 0.05, 0.1, 0.2)],
    "verlet": [(c, {}) for c in (0.1, 0.15, 0.2, 0.25, 0.3)],
    "symplectic_verlet": [(c, {}) for c in (0.25, 0.3, 0.4, 0.5, 0.6, 0.8)],
    "rk4": [(c, {}) for c in (0.25, 0.5, 0.75, 1.0, 1.25, 1.5)],
    "rk45": [(c, {}) for c in (0.5, 1.0, 1.5, 3.0, 10.0)],
    "midpoint": [(c, {}) for c in (0.25, 0.5, 1.0, 1.5)],
    "midpoint_relaxed": [(c, RELAXED) for c in (1.5, 2.0, 3.0, 4.0)],
}


def run(label, cfl, extra, end, dp):
    scheme = label.split("_relaxed")[0]
    overrides = [("dp", dp), ("time.integrator", scheme), ("time.cfl", cfl), ("time.end", end),
                 ("output.progress", False)] + list(extra.items())
    sim = wcsph.Simulation(load("dam_break_2d_bi", overrides))
    t0 = time.perf_counter()
    try:
        summary = sim.run(progress=False)
    except wcsph.SimulationError as e:
        return {"scheme": label, "cfl": cfl, "ok": False, "message": str(e)[:120], "t": sim.t,
                "wall_s": time.perf_counter() - t0}
    v, m = sim.host(sim.fluid, "v", "m")
    ek = 0.5 * float((m * (v.astype(float) ** 2).sum(axis=0)).sum())
    stats = getattr(sim.integrator, "stats", {})
    return {"scheme": label, "cfl": cfl, "ok": True, "steps": summary["steps"], "evaluations": summary["evaluations"],
            "wall_s": summary["wall_time_s"] - summary["compile_time_s"], "kinetic_energy": ek,
            "n_fluid": summary["n_fluid"], "iterations_last": stats.get("midpoint_iterations")}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--end", type=float, default=1.0)
    ap.add_argument("--dp", type=float, default=0.005)
    ap.add_argument("--schemes", nargs="+", default=list(LADDERS))
    ap.add_argument("--out", default=None, help="write all runs as JSON lines")
    a = ap.parse_args()
    ref = run("symplectic_verlet", 0.25, {}, a.end, a.dp)
    print(json.dumps(ref), flush=True)
    rows = []
    for scheme in a.schemes:
        best = None
        for cfl, extra in LADDERS[scheme]:
            r = run(scheme, cfl, extra, a.end, a.dp)
            if r["ok"] and abs(r["kinetic_energy"] / ref["kinetic_energy"] - 1) > 0.25:
                r["ok"], r["message"] = False, "kinetic energy off the reference by more than 25 %"
            print(json.dumps(r), flush=True)
            if a.out:
                with open(a.out, "a") as f:
                    f.write(json.dumps(r) + "\n")
            if not r["ok"]:
                break
            best = r
        rows.append((scheme, best))
    print(f"\ndam_break_2d_bi, dp = {a.dp}, {ref['n_fluid']} fluid particles, to t = {a.end} s")
    print("| integrator | largest stable cfl | steps | evaluations/step | wall time [s] |")
    print("|---|---|---|---|---|")
    for scheme, b in rows:
        if b is None:
            print(f"| {scheme} | none on the ladder | | | |")
            continue
        print(f"| {scheme} | {b['cfl']} | {b['steps']} | {b['evaluations'] / b['steps']:.1f} | {b['wall_s']:.1f} |")


if __name__ == "__main__":
    main()
