"""MPI ranks against threads, and the halo exchange's share of the step.

    python benchmarks/parallel.py                      # strong: 100 k and 400 k, weak: 1-8 ranks
    python benchmarks/parallel.py --sizes 100000 --rounds 2 --no-weak
    python benchmarks/parallel.py --balance-demo --sizes 100000   # balance by counts vs by times

**Strong scaling** (the 2D classic dam break at each size): 1 rank x 2 threads, 2 ranks x 1
thread and 1 rank x 1 thread, alternated over ``--rounds`` rounds (a busy host moves one
round, not the comparison); the step time is the median of windows of a fixed step count
(every rank steps together), the least over rounds. The exchange share is the time in the
halo updates and the redistribution (migration, ghosts; not the sort a single process does
too) over the stepping time, the largest over ranks.

**Weak scaling** (a tank at rest, ``--per-rank`` particles per rank, as wide as the ranks):
1, 2, 4 and 8 ranks of one thread each. On a 2-core host more than 2 ranks oversubscribe
the cores, so the step time there says nothing; the figures are the exchange time and the
bytes a rank sends per step, which should not grow with the rank count (each rank has two
neighbours at most).
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).parent


def worker(args):
    """One configuration, run by each rank (or a single process): prints a JSON line (rank 0)."""
    sys.path.insert(0, str(HERE))
    import numpy as np

    import wcsph
    from wcsph.case.config import read_toml, resolve, validate

    if args.weak:
        data = read_toml(resolve("hydrostatic_2d"))
        ranks = int(os.environ.get("PMI_SIZE", os.environ.get("OMPI_COMM_WORLD_SIZE", "1")))
        width = 1.0 * ranks
        data["fluid"][0]["max"] = [width, 0.5]
        data["tank"]["max"] = [width, 0.7]
        data["dp"] = (0.5 / args.n) ** 0.5
        data["physics"]["gravity_ramp_time"] = 0.0
        case = validate(data, src="weak")
    else:
        from _measure import COLUMN
        from wcsph.case.config import load

        case = load("dam_break_2d", [("dp", (COLUMN["dam_break_2d"] / args.n) ** 0.5),
                                     ("parallel.balance", args.balance), ("parallel.axis", "x")])
    sim = wcsph.Simulation(case)
    par = sim.par
    for _ in range(args.warm):  # compile or load the loops (and let the balancer settle)
        sim.step(sim.time_step())
    comm = par.comm if par is not None else None
    per, shares, exchange, sent = [], [], [], []
    for _ in range(args.windows):
        if comm is not None:
            comm.Barrier()
        e0 = (par.exchange_time, par.sent_bytes) if par else (0.0, 0)
        t0 = time.perf_counter()
        for _ in range(args.steps):
            sim.step(sim.time_step())
        if comm is not None:
            comm.Barrier()
        elapsed = time.perf_counter() - t0
        per.append(elapsed / args.steps)
        if par is not None:
            ex = par.exchange_time - e0[0]
            shares.append(float(par.max([ex / elapsed])[0]))
            exchange.append(float(par.max([ex / args.steps])[0]))
            sent.append(float(par.max([(par.sent_bytes - e0[1]) / args.steps])[0]))
    n = sim.n_fluid()  # a collective: every rank calls it
    if par is None or par.rank == 0:
        med = statistics.median
        print(json.dumps({"n": n, "step_s": med(per), "exchange_share": med(shares) if shares else 0.0,
                          "exchange_s": med(exchange) if exchange else 0.0, "sent_bytes": med(sent) if sent else 0.0,
                          "ranks": par.size if par else 1, "cuts": [int(c) for c in par.cuts] if par else [],
                          "rebalances": par.rebalances if par else 0}), flush=True)


def launch(ranks, threads, n, steps, windows, weak=False, balance="count", warm=3, pinned=False):
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
    cmd = [sys.executable, __file__, "--worker", "--n", str(n), "--steps", str(steps), "--windows", str(windows),
           "--balance", balance, "--warm", str(warm)]
    if weak:
        cmd.append("--weak")
    mpiexec = shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or "mpiexec"
    if pinned:  # rank r on core r (MPMD form of mpiexec)
        full = [mpiexec]
        for r in range(ranks):
            full += (([":"] if r else []) + ["-n", "1", "taskset", "-c", str(r)] + cmd)
        cmd = full
    elif ranks > 1:
        cmd = [mpiexec, "-n", str(ranks)] + cmd
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr[-2000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def balance_demo(args):
    """``balance = "count"`` against ``"time"`` when one rank's core is shared with a busy
    process: the count balance keeps half the particles on the slowed rank, the time balance
    moves the cut until both ranks take as long."""
    n = args.sizes[0]
    print(f"\n{n} particles, 2 ranks pinned to cores 0 and 1, a busy process on core 0 too")
    print("\n| balance | step (ms), least over rounds | all rounds (ms) | cuts at the end | rebalances |")
    print("|---|---|---|---|---|")
    busy = subprocess.Popen(["taskset", "-c", "0", sys.executable, "-c", "while True: pass"])
    try:
        got = {"count": [], "time": []}
        for _ in range(args.rounds):
            for b in got:
                got[b].append(launch(2, 1, n, args.steps, args.windows, balance=b, warm=120, pinned=True))
    finally:
        busy.kill()
    for b, rs in got.items():
        best = min(rs, key=lambda r: r["step_s"])
        rounds = ", ".join(f"{r['step_s'] * 1e3:.1f}" for r in rs)
        print(f"| {b} | {best['step_s'] * 1e3:.1f} | {rounds} | {best['cuts']} | {best['rebalances']} |", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--weak", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, default=100_000, help=argparse.SUPPRESS)
    ap.add_argument("--steps", type=int, default=20, help="steps per timing window")
    ap.add_argument("--windows", type=int, default=5)
    ap.add_argument("--sizes", type=int, nargs="+", default=[100_000, 400_000])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--per-rank", type=int, default=50_000)
    ap.add_argument("--no-weak", action="store_true")
    ap.add_argument("--balance", default="count", help=argparse.SUPPRESS)
    ap.add_argument("--warm", type=int, default=3, help=argparse.SUPPRESS)
    ap.add_argument("--no-strong", action="store_true")
    ap.add_argument("--balance-demo", action="store_true",
                    help="2 ranks pinned to the 2 cores, a busy process beside rank 0: cuts by counts vs by times")
    args = ap.parse_args()
    if args.worker:
        return worker(args)
    import platform

    print(f"host: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"{args.rounds} rounds, {args.windows} windows of {args.steps} steps")
    if args.balance_demo:
        return balance_demo(args)
    configs = [] if args.no_strong else [(1, 2), (2, 1), (1, 1)]
    print("\n| particles | ranks x threads | step (ms), least over rounds | all rounds (ms) | exchange share |")
    print("|---|---|---|---|---|")
    for n in args.sizes:
        steps = max(4, args.steps * 100_000 // n)
        got = {c: [] for c in configs}
        for _ in range(args.rounds):
            for c in configs:
                got[c].append(launch(*c, n, steps, args.windows))
        for c in configs:
            best = min(got[c], key=lambda r: r["step_s"])
            rounds = ", ".join(f"{r['step_s'] * 1e3:.1f}" for r in got[c])
            share = f"{100 * best['exchange_share']:.1f} %" if c[0] > 1 else "-"
            print(f"| {best['n']} | {c[0]} x {c[1]} | {best['step_s'] * 1e3:.2f} | {rounds} | {share} |", flush=True)
    if args.no_weak:
        return
    print(f"\nweak scaling, {args.per_rank} particles per rank, one thread each (over 2 ranks: oversubscribed)")
    print("\n| ranks | particles | step (ms) | exchange per step (ms), slowest rank | sent per step and rank (kB) |")
    print("|---|---|---|---|---|")
    for ranks in (1, 2, 4, 8):
        r = launch(ranks, 1, args.per_rank, max(4, args.steps // 2), 3, weak=True)
        print(f"| {ranks} | {r['n']} | {r['step_s'] * 1e3:.1f} | {r['exchange_s'] * 1e3:.2f} | "
              f"{r['sent_bytes'] / 1e3:.0f} |", flush=True)


if __name__ == "__main__":
    main()
