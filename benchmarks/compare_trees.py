"""Step time of the shipped dam breaks for two source trees, measured in alternating processes.

    python benchmarks/compare_trees.py OLD_SRC NEW_SRC [--rounds 3] [--seconds 4]

OLD_SRC and NEW_SRC are ``src`` directories of two checkouts (``git worktree add``); each
measurement is a fresh process with that tree first on ``sys.path``, one case at a time, the
two trees alternating so that a drift of the host's speed falls on both. Prints per case the
median step time of each tree and their ratio (new / old); the ratios are what to quote, the
absolute times are this host's.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

#: (case, fluid particles): the four shipped dam breaks at their sizes of issue 20, and a small one
CASES = [("dam_break_2d", 100_000), ("dam_break_2d_bi", 100_000), ("dam_break_3d", 46_000),
         ("dam_break_3d_bi", 46_000), ("dam_break_2d_bi", 2_500)]

PROBE = """
import json, sys, time
sys.path.insert(0, {bench!r})
from _measure import rate, setup
sim = setup({case!r}, {n})
dt, _ = rate(sim, {seconds})
print(json.dumps({{"step_s": dt, "n": sim.fluid.n}}))
"""


def measure(src, case, n, seconds):
    env = dict(os.environ, PYTHONPATH=str(src))
    code = PROBE.format(bench=str(Path(__file__).parent), case=case, n=n, seconds=seconds)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])["step_s"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--only", default="", help="only the cases whose name contains this")
    a = ap.parse_args()
    for case, n in CASES:
        if a.only not in case:
            continue
        times = {"old": [], "new": []}
        for _ in range(a.rounds):
            for tag in ("old", "new"):
                times[tag].append(measure(getattr(a, tag), case, n, a.seconds))
        old, new = statistics.median(times["old"]), statistics.median(times["new"])
        print(f"{case:16s} {n:7d}  old {old * 1e3:8.2f} ms  new {new * 1e3:8.2f} ms  new/old {new / old:.3f}  "
              f"(rounds: {[round(t * 1e3, 2) for t in times['old']]} / {[round(t * 1e3, 2) for t in times['new']]})",
              flush=True)


if __name__ == "__main__":
    main()
