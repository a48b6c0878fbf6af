"""Per step of the CUDA backend, counted in Numba's CUDA simulator (no GPU needed): kernel
launches (by kernel) and the scalars their arguments make (numba-cuda's dispatcher converts
each in Python, a host cost per launch), launches not queued on the run's stream, device
allocations, host-to-device and device-to-host copies, and the host's waits: for the whole
queue (a stream's synchronize) or for an earlier copy (an event's). These
are what bind a small or medium GPU step (each launch costs microseconds of host time, each
device-to-host copy a synchronisation), so they are counted where no GPU is lent.

    python benchmarks/cuda_counts.py [CASE] [--dp DP] [--steps N]

Runs CASE (default dam_break_2d_bi) for 3 warm-up steps, then counts over N more (default 4)
and prints the counts per step.
"""
import argparse
import collections
import os
import sys

os.environ["NUMBA_ENABLE_CUDASIM"] = "1"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", nargs="?", default="dam_break_2d_bi")
    ap.add_argument("--dp", type=float, default=0.05)
    ap.add_argument("--steps", type=int, default=4)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=JSON",
                    help="a case override, e.g. --set time.dt=1e-4 (the value read as JSON)")
    ap.add_argument("--json", action="store_true", help="print the counts per step as one JSON line")
    ap.add_argument("--threads", type=int, default=0,
                    help="threads per block (default the backend's; fewer run faster in the simulator, same counts)")
    a = ap.parse_args(argv)

    from numba.cuda.simulator import kernel
    from numba.cuda.simulator.cudadrv import devicearray

    import wcsph
    import wcsph.backends.cuda as cuda_backend
    from wcsph.case.config import load

    if a.threads:
        cuda_backend.THREADS = a.threads

    counts = collections.Counter()
    counting = [False]

    def wrap(owner, name, key):
        original = getattr(owner, name)

        def counted(*args, **kw):
            if counting[0]:
                counts[key(args) if callable(key) else key] += 1
            return original(*args, **kw)

        setattr(owner, name, counted)

    def leaves(a):
        """The scalars numba-cuda passes for a kernel argument: an array as its meminfo,
        parent, size, item size, data pointer, shape and strides (5 + 2 ndim), a tuple or a
        view as its members'."""
        if isinstance(a, tuple):
            return sum(leaves(b) for b in a)
        if hasattr(a, "shape") and hasattr(a, "strides") and len(a.shape):  # not a NumPy scalar
            return 5 + 2 * len(a.shape)
        return 1

    def kname(k):
        return getattr(k.fn, "__qualname__", "?").replace(".<locals>.", ".").replace(".<locals>", "")

    original_call = kernel.FakeCUDAKernel.__call__

    def call(k, *args, **kw):
        if counting[0]:
            if k._device:
                counts["device function " + kname(k)] += 1
            else:
                counts["launch " + kname(k)] += 1
                n = leaves(args)
                counts["kernel arguments"] += n
                counts["_largest"] = max(counts["_largest"], n)
        return original_call(k, *args, **kw)

    kernel.FakeCUDAKernel.__call__ = call
    original_configure = kernel.FakeCUDAKernel.__getitem__

    def configure(k, configuration):
        if counting[0] and (len(configuration) < 3 or configuration[2] in (0, None)):
            counts["launch off the stream"] += 1
        return original_configure(k, configuration)

    kernel.FakeCUDAKernel.__getitem__ = configure
    from numba.cuda.simulator import api

    wrap(api.stream, "synchronize", "host waits for the queue")
    wrap(api.Event, "synchronize", "host waits for an earlier copy")
    wrap(devicearray.FakeCUDAArray, "copy_to_host", "device->host copy")
    # an upload into an existing device array (P's record): a host source, not a device one
    wrap(devicearray.FakeCUDAArray, "copy_to_device",
         lambda args: "host->device copy" if not hasattr(args[1], "copy_to_host") else "device->device copy")
    import numba.cuda as cuda

    for name, key in (("device_array", "allocation"), ("to_device", "host->device copy")):
        original = getattr(cuda, name)

        def counted(*args, _o=original, _k=key, **kw):
            if counting[0]:
                counts[_k] += 1
            return _o(*args, **kw)

        setattr(cuda, name, counted)

    import json

    extra = [(k, json.loads(v)) for k, v in (o.split("=", 1) for o in a.set)]
    case = load(a.case, [("dp", a.dp), ("output.vtk", False), ("output.progress", False)] + extra)
    sim = wcsph.Simulation(case, backend="cuda")
    def advance(n):
        for _ in range(n):
            sim.step(sim.time_step())

    advance(3)
    counting[0] = True
    advance(a.steps)
    counting[0] = False
    launches = sum(v for k, v in counts.items() if k.startswith("launch ") and k != "launch off the stream")
    largest = counts.pop("_largest", 0)
    if a.json:
        print(json.dumps({"launches": launches / a.steps, "fluid": sim.n_fluid(), "largest launch": largest,
                          **{k: v / a.steps for k, v in counts.items() if not k.startswith(("launch ", "device f")) or k == "launch off the stream"}}))
        return 0
    print(f"{a.case}, dp = {a.dp}, {sim.n_fluid()} fluid particles, per step over {a.steps} steps:")
    print(f"  kernel launches: {launches / a.steps:g}")
    print(f"  kernel arguments (numba-cuda's scalars), the largest launch: {largest}")
    for k, v in sorted(counts.items()):
        if k.startswith("device function"):  # the simulator calls them as kernels; a GPU inlines them
            continue
        print(f"    {k}: {v / a.steps:g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
