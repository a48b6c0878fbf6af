"""CUDA backend (numba-cuda): the same physics functions compiled as device functions inside
one kernel per pass, one thread per particle of set I.

Sorting computes cell ids on the device and orders them with CuPy when it is installed (on a
real GPU), else on the host; this is correct everywhere, including the simulator
(``NUMBA_ENABLE_CUDASIM=1``) used by the tests, but the host round trip is the first thing to
replace for speed (a device radix sort).
"""
import math
import os

import numpy as np
from numba import cuda

from .walk import make_periodic_walk, make_run_visitor

THREADS = 128

_cp = None
if os.environ.get("NUMBA_ENABLE_CUDASIM", "0") != "1":
    try:  # CuPy sorts and reduces on the device when present
        import cupy as _cp
    except ImportError:  # pragma: no cover - depends on the machine
        _cp = None


def _blocks(n):
    return max(1, math.ceil(n / THREADS))


@cuda.jit
def _cell_ids(x, origin, inv_cell, nx, ny, nz, ncells, k, cell):
    i = cuda.grid(1)
    if i >= x.shape[1]:
        return
    cx = int(math.floor((x[0, i] - origin[0]) * inv_cell[0]))
    cy = int(math.floor((x[1, i] - origin[1]) * inv_cell[1]))
    inside = k <= cx < nx - k and k <= cy < ny - k
    cz = 0
    if x.shape[0] == 3:
        cz = int(math.floor((x[2, i] - origin[2]) * inv_cell[2]))
        inside = inside and k <= cz < nz - k
    cell[i] = cx + nx * (cy + ny * cz) if inside else ncells


@cuda.jit
def _gather1(src, perm, dst):
    k = cuda.grid(1)
    if k < dst.size:
        dst[k] = src[perm[k]]


@cuda.jit
def _gather2(src, perm, dst):
    k = cuda.grid(1)
    if k < dst.shape[1]:
        for d in range(src.shape[0]):
            dst[d, k] = src[d, perm[k]]


@cuda.jit
def _drop_cells(cell, drop, ncells):
    i = cuda.grid(1)
    if i < cell.size and drop[i]:
        cell[i] = ncells


@cuda.jit
def _scatter1(src, idx, dst):
    k = cuda.grid(1)
    if k < idx.size:
        dst[idx[k]] = src[k]


@cuda.jit
def _scatter2(src, idx, dst):
    k = cuda.grid(1)
    if k < idx.size:
        for d in range(src.shape[0]):
            dst[d, idx[k]] = src[d, k]


@cuda.jit
def _speeds(x, v, a, out):
    """out[0, i] = |v|^2, out[1, i] = |a|^2, out[2, i] = 1 if anything is non-finite."""
    i = cuda.grid(1)
    if i >= x.shape[1]:
        return
    s = 0.0
    q = 0.0
    ok = True
    for d in range(x.shape[0]):
        s += v[d, i] * v[d, i]
        q += a[d, i] * a[d, i]
        ok = ok and math.isfinite(x[d, i])
    ok = ok and math.isfinite(s) and math.isfinite(q)
    out[0, i] = s if ok else 0.0
    out[1, i] = q if ok else 0.0
    out[2, i] = 0.0 if ok else 1.0


@cuda.jit
def _wrap(x, lo, length, inv_cell, origin, k, real, axes):
    """The CPU backend's ``_wrap``, one thread per particle."""
    i = cuda.grid(1)
    if i >= x.shape[1]:
        return
    for m in range(axes.size):
        a = axes[m]
        xa = x[a, i]
        if xa < lo[a] or xa >= lo[a] + length[a]:
            xa = lo[a] + (xa - lo[a]) % length[a]
            c = int(math.floor((xa - origin[a]) * inv_cell[a]))
            if c < k or c >= k + real[a]:
                xa = lo[a]
            x[a, i] = xa


def _make_pass_kernel(dim, init, pair1, pair2, finish, use2, zero, periodic=None):
    """The one CUDA neighbour loop, the same walk as the CPU backend's, one thread per i."""
    visit1 = make_run_visitor(dim, pair1, zero)
    visit2 = make_run_visitor(dim, pair2, zero)
    if periodic is not None and any(periodic):
        walk = make_periodic_walk(dim, visit1, visit2, use2, zero, periodic)

        @cuda.jit
        def run_periodic(I, J1, J2, P, G):
            i = cuda.grid(1)
            if i >= I.x.shape[1]:
                return
            zi = I.x[2, i] if dim == 3 else zero
            acc = walk(i, I.x[0, i], I.x[1, i], zi, I.cell[i], I, J1, J2, P, G, init(i, I, P))
            finish(i, I, P, acc)

        def launch_periodic(I, J1, J2, P, G):
            n = I.x.shape[1]
            if n:
                run_periodic[_blocks(n), THREADS](I, J1, J2, P, G)

        return launch_periodic

    @cuda.jit
    def run(I, J1, J2, P, G):
        i = cuda.grid(1)
        if i >= I.x.shape[1]:
            return
        c = I.cell[i]
        xi = I.x[0, i]
        yi = I.x[1, i]
        zi = I.x[2, i] if dim == 3 else zero
        acc = init(i, I, P)
        k = G.k
        kz = k if dim == 3 else 0
        for oz in range(-kz, kz + 1):
            for oy in range(-k, k + 1):
                cc = c + oy * G.sy + oz * G.sz
                acc = visit1(i, xi, yi, zi, I, J1, J1.start[cc - k], J1.start[cc + k + 1], P, acc)
                if use2:
                    acc = visit2(i, xi, yi, zi, I, J2, J2.start[cc - k], J2.start[cc + k + 1], P, acc)
        finish(i, I, P, acc)

    def launch(I, J1, J2, P, G):
        n = I.x.shape[1]
        if n:
            run[_blocks(n), THREADS](I, J1, J2, P, G)

    return launch


def _make_map_kernel(fn):
    @cuda.jit
    def run(I, P):
        i = cuda.grid(1)
        if i < I.x.shape[1]:
            fn(i, I, P)

    def launch(I, P):
        n = I.x.shape[1]
        if n:
            run[_blocks(n), THREADS](I, P)

    return launch


def _make_reduce_kernel(fn):
    @cuda.jit
    def run(I, P, out):
        i = cuda.grid(1)
        if i < I.x.shape[1]:
            a, b, c = fn(i, I, P)
            out[0, i] = a
            out[1, i] = b
            out[2, i] = c

    def launch(I, P, owned=None):
        n = I.x.shape[1]
        if n == 0:
            return 0.0, 0.0, 0.0
        out = cuda.device_array((3, n), dtype=np.float64)
        run[_blocks(n), THREADS](I, P, out)
        return _reduce_rows(out, ("sum", "sum", "max"), owned)

    return launch


def _reduce_rows(out, ops, owned=None):
    """Each row of a (rows, n) device array reduced by its op ("sum" or "max"), on the
    device with CuPy when present, else on the host; over the columns with ``owned[i]``
    when given (a process of a decomposed run skips its ghost copies)."""
    if owned is not None:  # the host reduces a decomposed run's rows (staged, like its halo)
        mask = owned.copy_to_host() if hasattr(owned, "copy_to_host") else np.asarray(owned)
        o = out.copy_to_host()[:, mask.astype(bool)]
        return tuple(float(getattr(o[k], op)()) if o.shape[1] else 0.0 for k, op in enumerate(ops))
    o = _cp.asarray(out) if _cp is not None else out.copy_to_host()
    r = [getattr(o[k], op)() for k, op in enumerate(ops)]
    r = _cp.stack(r).get() if _cp is not None else r
    return tuple(float(v) for v in r)


class CudaBackend:
    name = "cuda"

    def to_device(self, a):
        return cuda.to_device(np.ascontiguousarray(a))

    def to_host(self, a):
        return a.copy_to_host() if hasattr(a, "copy_to_host") else np.asarray(a)

    def make_pass(self, dim, dtype, init, pair1, finish, pair2=None, cache=True, branchless=False,
                  periodic=None):
        """Same interface as the CPU backend; ``cache`` has no effect (kernels compile per
        process), nor ``branchless`` (a thread that skips a pair frees its warp's lane: the
        branch is the faster form on a GPU)."""
        use2 = pair2 is not None
        return _make_pass_kernel(dim, init, pair1, pair2 if use2 else pair1, finish, use2,
                                 np.dtype(dtype).type(0), periodic)

    def wrap(self, pset, grid):
        if not grid.any_periodic or not pset.n:
            return
        x = pset["x"]
        dt = np.dtype(x.dtype).type
        lo, length = grid.lengths()
        origin, inv = grid.geometry(dt)
        axes = np.array([a for a in range(grid.dim) if grid.periodic[a]], dtype=np.int64)
        real = np.asarray(grid.shape[: grid.dim], dtype=np.int64) - 2 * grid.reach
        _wrap[_blocks(pset.n), THREADS](x, cuda.to_device(lo.astype(dt)), cuda.to_device(length.astype(dt)),
                                         cuda.to_device(inv), cuda.to_device(origin), grid.reach,
                                         cuda.to_device(real), cuda.to_device(axes))

    def make_map(self, fn):
        return _make_map_kernel(fn)

    def make_reduce(self, fn):
        return _make_reduce_kernel(fn)

    def sort(self, pset, grid, drop=None):
        """As the CPU backend's ``sort`` (``drop``: a device array of flags)."""
        g = grid.view()
        x = pset["x"]
        n = pset.n
        origin, inv_cell = grid.geometry(np.dtype(x.dtype).type)
        if "cell" not in pset.arrays or pset["cell"].shape[0] != n:
            pset["cell"] = cuda.device_array(n, dtype=np.int64)
        cell = pset["cell"]
        if n:
            _cell_ids[_blocks(n), THREADS](x, cuda.to_device(origin), cuda.to_device(inv_cell), g.nx, g.ny, g.nz,
                                            g.ncells, g.k, cell)
            if drop is not None:
                _drop_cells[_blocks(n), THREADS](cell, drop, g.ncells)
        if _cp is not None:
            c = _cp.asarray(cell)
            perm_c = _cp.argsort(c, kind="stable") if n else _cp.zeros(0, dtype=_cp.int64)
            start = _cp.searchsorted(c[perm_c], _cp.arange(g.ncells + 2)).astype(_cp.int64)
            perm = cuda.as_cuda_array(perm_c.astype(_cp.int64))
            start_d = cuda.as_cuda_array(start)
            n_in = int(start[g.ncells].get())
        else:
            ch = cell.copy_to_host()
            perm_h = np.argsort(ch, kind="stable")
            start_h = np.searchsorted(ch[perm_h], np.arange(g.ncells + 2)).astype(np.int64)
            perm = cuda.to_device(perm_h)
            start_d = cuda.to_device(start_h)
            n_in = int(start_h[g.ncells])
        pset["start"] = start_d
        pset["_perm"] = perm  # new position -> old (a decomposed run maps its halo lists through it)
        dropped = n - n_in
        fields = pset.sorted_fields()
        scratch = [k for k in pset.per_particle() if k not in fields]
        for k in fields:  # the first n_in of the new order: the dropped ones are sorted last
            a = pset[k]
            out = cuda.device_array(a.shape[:-1] + (n_in,), dtype=a.dtype)
            if n_in:
                (_gather1 if a.ndim == 1 else _gather2)[_blocks(n_in), THREADS](a, perm, out)
            pset[k] = out
        if dropped:
            for k in scratch:  # written before they are read: only their size matters
                pset[k] = cuda.device_array(pset[k].shape[:-1] + (n_in,), dtype=pset[k].dtype)
            pset.n = n_in
        return dropped

    def take(self, a, idx):
        """a[..., idx] on the host (a halo's send buffer, staged through the host); ``idx``
        a device array of int64."""
        n = idx.size
        flat = a.reshape(-1, a.shape[-1]) if a.ndim > 2 else a
        out = cuda.device_array(flat.shape[:-1] + (n,), dtype=a.dtype)
        if n:
            (_gather1 if flat.ndim == 1 else _gather2)[_blocks(n), THREADS](flat, idx, out)
        return out.copy_to_host().reshape(a.shape[:-1] + (n,))

    def put(self, a, idx, values):
        """a[..., idx] = values (host), in place on the device."""
        n = idx.size
        if not n:
            return
        flat = a.reshape(-1, a.shape[-1]) if a.ndim > 2 else a
        src = cuda.to_device(np.ascontiguousarray(values.reshape(flat.shape[:-1] + (n,))))
        (_scatter1 if flat.ndim == 1 else _scatter2)[_blocks(n), THREADS](src, idx, flat)

    def index(self, idx):
        return cuda.to_device(np.ascontiguousarray(idx, dtype=np.int64))

    def check(self, pset, owned=None):
        n = pset.n
        if n == 0:
            return 0.0, 0.0, 0
        out = cuda.device_array((3, n), dtype=np.float64)
        _speeds[_blocks(n), THREADS](pset["x"], pset["v"], pset["dvdt"], out)
        vmax2, amax2, bad = _reduce_rows(out, ("max", "max", "sum"), owned)
        return vmax2, amax2, int(bad)
