"""Start-up of every shipped case in a fresh process: cold (an empty Numba cache: every loop
compiles) and warm (the second process: every loop loads from the cache). Reports the
set-up plus first step (``compile_time_s`` of run.json) and the whole process's wall time.

    python benchmarks/warm_start.py [--cases dam_break_2d ...]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from wcsph.case.config import shipped_cases


def start(name, cache, out):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    cmd = [sys.executable, "-m", "wcsph.cli", "run", name, "-o", str(out), "--no-progress",
           "--set", "time.max_steps=2", "--set", "output.vtk=false"]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=env)
    wall = time.perf_counter() - t0
    return json.loads((out / "run.json").read_text())["compile_time_s"], wall


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", default=shipped_cases())
    args = ap.parse_args()
    print("| case | cold: set-up + first step (s) | cold process (s) | warm: set-up + first step (s) "
          "| warm process (s) |")
    print("|---|---:|---:|---:|---:|")
    for name in args.cases:
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            cold = start(name, tmp / "cache", tmp / "cold")
            warm = start(name, tmp / "cache", tmp / "warm")
        print(f"| {name} | {cold[0]:.1f} | {cold[1]:.1f} | {warm[0]:.2f} | {warm[1]:.2f} |", flush=True)


if __name__ == "__main__":
    main()
