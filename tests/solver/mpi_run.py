"""Run cases for a number of steps and save the final fluid state, sorted by particle id, to
an .npz: run under ``mpiexec -n N`` by tests/solver/test_parallel.py and compared with the same
script on one process. Usage: mpi_run.py OUT.npz STEPS CASE [KEY=VALUE ...] [-- CASE ...]"""
import sys

import numpy as np

from wcsph.case.config import load, parse_override
from wcsph import Simulation


def run(case_name, sets, steps):
    case = load(case_name, [parse_override(s) for s in sets])
    sim = Simulation(case)
    for _ in range(steps):
        sim.step(min(sim.time_step(), case["time"]["end"] - sim.t))
    names = ["x", "v", "rho", "id"]
    arrays = dict(zip(names, sim.owned_host(*names)))
    if sim.par is not None:
        arrays = sim.par.gather(arrays)
        if sim.par.rank != 0:
            return None
    order = np.argsort(arrays["id"])
    out = {k: a[..., order] for k, a in arrays.items()}
    out["t"] = np.array(sim.t)
    if sim.par is not None:
        out["rebalances"] = np.array(sim.par.rebalances)
        out["cuts"] = np.array(sim.par.cuts)
    return out


def main(argv):
    path, steps, rest = argv[0], int(argv[1]), argv[2:]
    runs, cur = [], []
    for a in rest:
        if a == "--":
            runs.append(cur)
            cur = []
        else:
            cur.append(a)
    runs.append(cur)
    results = {}
    for k, r in enumerate(runs):
        out = run(r[0], r[1:], steps)
        if out is not None:
            results.update({f"{k}.{name}": a for name, a in out.items()})
    if results:
        np.savez(path, **results)


if __name__ == "__main__":
    main(sys.argv[1:])
