"""Compile the CUDA backend's kernels for a real GPU architecture, with no GPU: every pass,
map and reduction a case launches, and the backend's own sort, scan, gather and check
kernels, through numba-cuda's compiler to PTX for a compute capability (default 9.0, the
H100/H200). Numba's CUDA simulator runs the kernels' Python source and accepts what the
CUDA compiler may refuse (a type it cannot unify, an unsupported call, a tuple it cannot
index); this is the check that the code a GPU would run compiles.

The kernels' argument types come from a few steps of the case on the CPU backend: a pass
receives the same particle-set views, parameter tuple and grid view on both backends (the
cell starts are int64 on the GPU, uint64 on the CPU; their type is mapped). Needs NVVM and
NVRTC (``pip install "numba-cuda[cu13]"``, in the ``test`` extra); no driver.

    python -m wcsph.validation.ptx CASE [--dp DP] [--cc 9.0]
"""
import argparse
import collections
import sys
import time

import numpy as np

#: (kind, builder of the CUDA kernel, argument values recorded at the first CPU call)
Recorded = collections.namedtuple("Recorded", "kind build args")


def available():
    """None when PTX can be made here, else why not (one line)."""
    try:
        from numba import cuda, types

        def k(a):
            a[0] = 1.0

        cuda.compile_ptx(k, (types.float64[:],), cc=(9, 0))
    except Exception as e:  # no NVVM or NVRTC: the toolkit's wheels are not installed
        return f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"
    return None


def _with_device_starts(a):
    """The argument as the CUDA backend passes it: cell starts in int64 (the CPU's are uint64)."""
    if hasattr(a, "_fields") and "start" in a._fields and a.start.dtype == np.uint64:
        return a._replace(start=a.start.astype(np.int64))
    return a


def record(case, steps=2):
    """The passes, maps and reductions of ``case`` (a validated case dict) with their first
    arguments, from ``steps`` steps on the CPU backend."""
    from ..solver.simulation import Simulation
    from ..backends.cpu import CpuBackend
    from ..backends.cuda import CudaBackend

    made = []
    originals = {k: getattr(CpuBackend, k) for k in ("make_pass", "make_map", "make_reduce", "make_tail", "sort",
                                                      "fuses_check")}

    def recorder(kind, build, launch):
        entry = {"kind": kind, "build": build, "args": None}
        made.append(entry)

        def call(*args, **kw):
            if entry["args"] is None:  # one converted view for a view passed twice (the kernel takes it once)
                done = {}
                entry["args"] = tuple(done.setdefault(id(a), _with_device_starts(a)) for a in args)
            return launch(*args, **kw)

        return call

    def make_pass(self, dim, dtype, init, pair1, finish, pair2=None, cache=True, branchless=False, periodic=None,
                  then=None, parts=None, keep=None):
        launch = originals["make_pass"](self, dim, dtype, init, pair1, finish, pair2, cache, branchless, periodic,
                                        then, parts, keep)
        return recorder("pass", lambda: CudaBackend().make_pass(dim, dtype, init, pair1, finish, pair2,
                                                                periodic=periodic, then=then, keep=keep), launch)

    def make_map(self, fn, then=None):
        return recorder("map", lambda: CudaBackend().make_map(fn, then), originals["make_map"](self, fn, then))

    def make_reduce(self, fn):
        return recorder("reduce", lambda: CudaBackend().make_reduce(fn), originals["make_reduce"](self, fn))

    def make_tail(self, dim, dtype, fn, walk=None, parts=None):
        return recorder("tail", lambda: CudaBackend().make_tail(dim, dtype, fn, walk),
                        originals["make_tail"](self, dim, dtype, fn, walk, parts))

    placed = {}

    def sort(self, pset, grid, drop=None, refresh=None, inside=False):
        dropped = originals["sort"](self, pset, grid, drop, refresh, inside)
        if refresh is not None and "sort" not in placed:  # the launch that moves the fields and makes p, V
            fn, _, view, P = refresh
            placed["sort"] = {"kind": "sort", "build": lambda: _PlaceThen(fn, type(P)),
                              "args": (_with_device_starts(view(pset)), P)}
            made.append(placed["sort"])
        return dropped

    CpuBackend.make_pass, CpuBackend.make_map, CpuBackend.make_reduce = make_pass, make_map, make_reduce
    # the tails as a backend that checks in them makes them (the CPU then ignores ``measure``)
    CpuBackend.make_tail, CpuBackend.sort, CpuBackend.fuses_check = make_tail, sort, True
    try:
        sim = Simulation(case, backend="cpu")
        for _ in range(steps):
            sim.step(sim.time_step())
    finally:
        for k, v in originals.items():
            setattr(CpuBackend, k, v)
    # the launch that makes an adaptive step's size on the device (``TimeStep.parameters``)
    stepped = sim.model.stepped_values()
    made.append({"kind": "size", "build": lambda: _Sizer(stepped), "args": (None, sim.P)})
    made.append({"kind": "scan+size", "build": lambda: _Sizer(stepped, fused=True), "args": (None, sim.P)})
    return [Recorded(e["kind"], e["build"], e["args"]) for e in made if e["args"] is not None]


class _Sizer:
    """The step's sizing on the device (``CudaBackend.size_step``) as a recorded kernel: its
    own launch, or with ``fused`` in the sort's scan."""

    def __init__(self, stepped, fused=False):
        from ..backends import cuda as cb
        from ..physics.slots import step_value
        from ..solver.timestep import stable_step

        key = (stable_step, stepped, step_value)
        self.kernel = cb._scan_sized(key) if fused else cb._sizer(*key)

    def kernel_of(self, T):
        return self.kernel


class _PlaceThen:
    """The sort's launch that also makes p and V (``cuda._place_then``), as a recorded kernel."""

    def __init__(self, fn, T):
        from ..backends import cuda as cb

        self.kernel = cb._place_then(fn, T)

    def kernel_of(self, T):
        return self.kernel


def _kernel_args(r, dtype, dim):
    """The CUDA kernel's arguments for a recorded call of the CPU backend's (``P`` as the
    one-record array the kernels read it from)."""
    from ..backends.cuda import params_record

    if r.kind == "reduce":
        return (r.args[0], params_record(r.args[1]), np.zeros((3, 1)))
    i64 = np.zeros(4, dtype=np.int64)
    n = np.int64(4)
    if r.kind in ("size", "scan+size"):  # P's record, the check's ring, the rows, (cfl, h, c0, force_cfl, nu)
        size = (params_record(r.args[1]), np.zeros((4, 5, 1)), n, n, *([0.1] * 5))
        return (i64, n, i64, i64, i64, i64[:1], *size) if r.kind == "scan+size" else size
    if r.kind == "sort":
        x = np.zeros((dim, 4), dtype=dtype)
        f = np.zeros(4, dtype=dtype)
        return (i64, i64, i64, i64, (((x, f[None]), (x, f[None])), ((i64[None],), (i64[None],))), n, r.args[0],
                params_record(r.args[1]))
    if r.kind == "tail":  # (I, P[, F, J, G]) and the check's arguments
        I, P = r.args[:2]
        F, J, G = r.args[2:5] if len(r.args) >= 5 and r.args[2] is not None else (I, I, np.zeros(1, dtype=np.int8))
        f = np.zeros(3, dtype=dtype)
        part = np.zeros((4, 2))
        return (I, params_record(P), F, J, G, True, f, f, n, n, n, n, n, np.zeros(4, dtype=np.int8), part,
                part[:, :1], i64[:1], i64, i64, i64, n)
    return (r.args[0], params_record(r.args[1])) + r.args[2:]


def _backend_kernels(dtype, dim):
    """(name, kernel, argument values) for the backend's own kernels in one precision."""
    from ..backends import cuda as cb

    f = np.zeros(4, dtype=dtype)
    x = np.zeros((dim, 4), dtype=dtype)
    i64 = np.zeros(4, dtype=np.int64)
    i8 = np.zeros(1, dtype=np.int8)
    part = np.zeros((4, 2))
    n = np.int64(4)
    return [
        ("_cell_ids_counted", cb._cell_ids_counted, (x, f[:3], f[:3], n, n, n, n, n, np.zeros(4, dtype=np.uint8),
                                                     False, i64, i64, i64, n)),
        ("_histogram", cb._histogram, (i64, i64, i64, n)),
        ("_zero", cb._zero, (i64,)),
        ("_scan_chunks", cb._scan_chunks, (i64, n, i64, i64, i64, i64[:1])),
        ("_scatter_cells", cb._scatter_cells, (i64, i64, i64)),
        ("_place_cells", cb._place_cells, (i64, i64, i64, i64)),
        ("_place_fields", cb._place_fields, (i64, i64, i64, i64, (((x, f[None]), (x, f[None])), ((i64[None],), (i64[None],))),
                                             n)),
        ("_wrap", cb._wrap, (x, f[:3], f[:3], f[:3], f[:3], n, i64, i64)),
        ("_reduce_blocks", cb._reduce_blocks, (part, i8, i8, False, part, part[:, :1], i64[:1])),
        ("_body_sums", cb._body_sums, (x, x, i64, i64, np.zeros((2, 3)), np.zeros((2, 6)))),
        ("_check_blocks", cb._check_blocks, (x, x, x, f[:3], f[:3], n, n, n, n, n, i8, False, i8, part, part[:, :1],
                                             i64[:1], True, i64, i64, i64, n)),
    ]


def _use_capability(cc):
    """Device functions compile for the current device's capability; with no device, for cc."""
    import numba.cuda.dispatcher as dispatcher

    class Device:
        compute_capability = cc

    dispatcher.get_current_device = lambda: Device


def compile_case(case, cc=(9, 0), steps=2, log=None):
    """Compile every kernel ``case`` launches (and the backend's own, in its precision) to PTX
    for capability ``cc``. Returns [(name, seconds, PTX characters)]; raises the compiler's
    error naming the kernel that failed."""
    from numba import cuda, typeof

    _use_capability(cc)
    done = []

    def compile_one(name, kernel, args):
        t0 = time.perf_counter()
        try:
            ptx, _ = cuda.compile_ptx(kernel.py_func, tuple(typeof(a) for a in args), cc=cc)
        except Exception as e:
            raise RuntimeError(f"{name}: {e}") from e
        done.append((name, time.perf_counter() - t0, len(ptx)))
        if log:
            log(f"{name}: {done[-1][1]:.1f} s, {len(ptx)} characters of PTX")

    rec = record(case, steps)
    dtype = np.float32 if case.get("precision") == "float32" else np.float64
    for name, kernel, args in _backend_kernels(dtype, case["dim"]):
        compile_one(name, kernel, args)
    from ..backends.cuda import params_record

    for k, r in enumerate(rec):
        launch = r.build()
        if hasattr(launch, "kernel_for"):  # a pass: its kernel for the views it was called with
            compile_one(f"{r.kind} {k}", *launch.kernel_for(*r.args, upload=params_record))
        else:
            P = r.args[1]
            compile_one(f"{r.kind} {k}", launch.kernel_of(type(P)), _kernel_args(r, dtype, case["dim"]))
    return done


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case")
    ap.add_argument("--dp", type=float)
    ap.add_argument("--cc", default="9.0", help="compute capability, e.g. 8.0, 9.0 (default)")
    a = ap.parse_args(argv)
    why = available()
    if why:
        print(f"cannot compile PTX here ({why}); install numba-cuda[cu13]", file=sys.stderr)
        return 2
    from ..case.config import load

    overrides = [("output.vtk", False), ("output.progress", False)] + ([("dp", a.dp)] if a.dp else [])
    case = load(a.case, overrides)
    cc = tuple(int(v) for v in a.cc.split("."))
    done = compile_case(case, cc, log=print)
    print(f"{len(done)} kernels compiled for sm_{cc[0]}{cc[1]} in {sum(t for _, t, _ in done):.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
