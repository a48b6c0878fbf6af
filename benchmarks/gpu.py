"""Speed of the CUDA backend's whole step: ms per step, fluid particle-steps per second, kernel
launches and host synchronisations (device-to-host copies, ``cuda.synchronize``) per step,
for the cases issue 21 names, as a markdown table for the README.

    python benchmarks/gpu.py [--cases 2d-100k 2d-1.6M spheric2 3d-5M] [--steps 50]
                             [--precision float32] [--scale 1.0] [--constant-dt] [--json] [--threads N]

Each case is set up at its particle count (dp from the fluid's volume), stepped ``--warmup``
times (compilation, Numba's cache), then counted over ``--count`` steps (launches and
synchronisations, by wrapping numba-cuda's dispatcher and copies; the wrappers are removed
again) and timed over ``--steps`` steps between two CUDA events, ``cuda.synchronize()`` on
both sides, in ``--windows`` windows whose median is reported. With ``NUMBA_ENABLE_CUDASIM=1``
it runs in Numba's CUDA simulator (times are then the simulator's, wall clock; the counts are
those of a GPU); ``--scale`` multiplies every particle count (``--scale 0.002`` makes a
2D case of 200 particles: the test suite runs it so).
"""
import argparse
import collections
import json
import os
import sys
import time

from _measure import COLUMN

#: name: (case, fluid particles or None, dp or None, what the issue compares it with)
CASES = {
    "2d-100k": ("dam_break_2d_bi", 100_000, None, "goal >= 100 M/s"),
    "2d-1.6M": ("dam_break_2d_bi", 1_600_000, None, ""),
    "spheric2": ("spheric2_3d", None, 0.01, "TNL-SPH 198 M/s (H100), goal >= 300 M/s"),
    "3d-5M": ("dam_break_3d_bi", 5_000_000, None, "goal >= 350 M/s"),
}

#: fluid volume (area in 2D) of each case, to choose dp for a particle count: the benchmarks' table
VOLUME = COLUMN


def dp_for(case, n=None, dp=None, scale=1.0):
    """The spacing that gives ``case`` about ``n`` * ``scale`` fluid particles (or ``dp`` with
    its count scaled by ``scale``)."""
    dim = 3 if case.endswith("_3d") or "_3d_" in case else 2
    if n is None:
        n = VOLUME[case] / dp ** dim
    return (VOLUME[case] / (n * scale)) ** (1.0 / dim)


class Counter:
    """Counts kernel launches, device-to-host copies and synchronisations while active
    (a GPU's classes or the simulator's, whichever numba-cuda runs)."""

    def __init__(self):
        from numba import cuda

        self.counts = collections.Counter()
        self.patches = []
        if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
            from numba.cuda.simulator import kernel
            from numba.cuda.simulator.cudadrv import devicearray

            self._wrap(kernel.FakeCUDAKernel, "__call__", lambda a: None if a[0]._device else "launches")
            self._wrap(devicearray.FakeCUDAArray, "copy_to_host", "syncs")
        else:
            from numba.cuda import dispatcher
            from numba.cuda.cudadrv import devicearray

            self._wrap(dispatcher.CUDADispatcher, "call", "launches")
            self._wrap(devicearray.DeviceNDArray, "copy_to_host", "syncs")
        self._wrap(cuda, "synchronize", "syncs")

    def _wrap(self, owner, name, key):
        original = getattr(owner, name)
        counts = self.counts

        def counted(*args, **kw):
            k = key(args) if callable(key) else key
            if k:
                counts[k] += 1
            return original(*args, **kw)

        setattr(owner, name, counted)
        self.patches.append((owner, name, original))

    def remove(self):
        for owner, name, original in reversed(self.patches):
            setattr(owner, name, original)


def measure(name, args):
    from numba import cuda

    import wcsph
    from wcsph.case.config import load

    case_name, n, dp, note = CASES[name]
    dp = dp_for(case_name, n, dp, args.scale)
    over = [("dp", dp), ("precision", args.precision), ("backend", "cuda"), ("output.vtk", False),
            ("output.progress", False)]
    t0 = time.perf_counter()
    sim = wcsph.Simulation(load(case_name, over))
    setup = time.perf_counter() - t0
    if args.constant_dt:  # the adaptive rule's first step, kept (the host then reads every few steps)
        dt = sim.time_step()
        sim = wcsph.Simulation(load(case_name, over + [("time.dt", dt)]))

    def advance(k):
        for _ in range(k):
            sim.step(sim.time_step())

    advance(args.warmup)
    cuda.synchronize()
    counter = Counter()
    try:
        advance(args.count)
    finally:
        counter.remove()
    cuda.synchronize()
    per = []
    for _ in range(args.windows):
        start, end = cuda.event(), cuda.event()
        cuda.synchronize()
        w0 = time.perf_counter()
        start.record()
        advance(args.steps)
        end.record()
        end.synchronize()
        cuda.synchronize()
        ms = cuda.event_elapsed_time(start, end) if hasattr(cuda, "event_elapsed_time") else -1.0
        if ms <= 0:  # the simulator's events keep no time
            ms = (time.perf_counter() - w0) * 1e3
        per.append(ms / args.steps)
    ms = sorted(per)[len(per) // 2]
    return {"case": name, "setup": case_name, "dp": dp, "fluid": int(sim.n_fluid()), "walls": int(sim.walls.n),
            "ms_per_step": ms, "M_per_s": sim.n_fluid() / ms * 1e-3,
            "launches": counter.counts["launches"] / args.count, "syncs": counter.counts["syncs"] / args.count,
            "setup_s": setup, "note": note, "dt": "constant" if args.constant_dt else "adaptive",
            "check_every": sim.check.every}


def device_name():
    from numba import cuda

    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        return "Numba's CUDA simulator (times are the simulator's, not a GPU's)"
    d = cuda.get_current_device()
    name = d.name.decode() if isinstance(d.name, bytes) else str(d.name)
    try:
        from importlib.metadata import version

        return f"{name}, numba-cuda {version('numba-cuda')}"
    except Exception:
        return name


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--precision", default="float32", choices=["float32", "float64"])
    ap.add_argument("--scale", type=float, default=1.0, help="multiplies every case's particle count")
    ap.add_argument("--warmup", type=int, default=5)
    ap.add_argument("--count", type=int, default=3, help="steps over which launches and syncs are counted")
    ap.add_argument("--steps", type=int, default=50, help="steps per timed window")
    ap.add_argument("--windows", type=int, default=3)
    ap.add_argument("--constant-dt", action="store_true",
                    help="a constant time step (the adaptive rule's first), as TNL-SPH runs its cases: the host "
                         "reads the checks every time.check_interval steps")
    ap.add_argument("--json", action="store_true", help="one JSON line per case instead of the table")
    ap.add_argument("--threads", type=int, default=0,
                    help="threads per block (default the backend's; fewer run faster in the simulator, same counts)")
    args = ap.parse_args(argv)
    if args.threads:
        import wcsph.backends.cuda as cuda_backend

        cuda_backend.THREADS = args.threads
    if not args.json:
        print(f"{args.precision}, {'constant' if args.constant_dt else 'adaptive'} time step, {device_name()}")
        print("| case | fluid particles | ms/step | M fluid particle-steps/s | launches/step | syncs/step | compared with |")
        print("|---|---:|---:|---:|---:|---:|---|")
    for name in args.cases:
        r = measure(name, args)
        if args.json:
            print(json.dumps(r), flush=True)
        else:
            print(f"| {name} ({r['setup']}, dp {r['dp']:.4g}) | {r['fluid']:,} | {r['ms_per_step']:.3f} | "
                  f"{r['M_per_s']:.1f} | {r['launches']:g} | {r['syncs']:g} | {r['note']} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
