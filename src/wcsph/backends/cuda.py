"""CUDA backend (numba-cuda): the same physics functions compiled as device functions inside
one kernel per pass, one thread per particle of set I.

Everything stays on the device, with numba-cuda alone (no CuPy), the same in the simulator
(``NUMBA_ENABLE_CUDASIM=1``) the tests run:

* the sort is a counting sort on the cell ids in four launches: an exclusive scan of the
  cells' histogram (the cell starts, each block starting from the sums of the chunks before
  its own), an atomic scatter of the particle indices into their cells, then each cell's
  indices put in increasing order (the scatter's order depends on the threads' timing; after
  it the permutation is exactly the CPU's stable argsort), then one gather of every field.
  The cell ids, their histogram and the chunk sums the scan starts from are counted by the
  check after the step before (a fifth launch only when the positions changed since);
* reductions (the step's largest speed and acceleration, a sum of residuals) are a block
  reduction in shared memory, whose results the last block to finish reduces in the same
  launch; only the few results cross to the host;
* the check after a step also counts the particles outside the grid: when none is, the next
  sort of those positions keeps every particle without reading the count back, so a step
  whose time step needs the check copies one small array to the host, once.

The grid constants are uploaded once per grid. The step's parameters ``P`` are one device
record per launch, not ~40 numbers by value, uploaded asynchronously only when they change
(``_params``); each kernel reads the record back into the namedtuple the CPU passes.
"""
import math

import numpy as np
from numba import config as numba_config
from numba import cuda

try:  # numba-cuda's own (the CUDA pipeline does not know Numba's)
    from numba.cuda.misc.special import literal_unroll
except ImportError:  # the simulator runs the Python source
    from numba import literal_unroll

from .walk import body_term, every, make_periodic_walk, make_run_visitor, particle_check

if numba_config.ENABLE_CUDASIM:
    # Numba's CUDA simulator runs each thread of a block as a Python thread, and every
    # ``syncthreads`` waits until each of them has had the interpreter: at Python's default
    # switch interval (5 ms) a block reduction's barriers cost seconds per launch. A shorter
    # interval makes the simulator's runs 4 times faster (the tests and
    # ``benchmarks/cuda_counts.py`` run there); on a GPU nothing changes.
    import sys
    import threading

    from numba.core import types as _types
    from numba.cuda.simulator.kernelapi import FakeCUDAShared
    from numba.np import numpy_support

    sys.setswitchinterval(1e-4)

    # The simulator gives a block's threads one shared array per source line, made by the
    # first thread to reach it: a look-up, then a store, with no lock between. Two threads
    # switched out between the two got arrays of their own, and a scan or a reduction over
    # "shared" memory read garbage (seen in cold test runs under load, more often at the
    # short switch interval above). The same allocation, under a lock.
    _SHARED_LOCK = threading.Lock()
    _simulator_shared_array = FakeCUDAShared.array

    def _shared_array(self, shape, dtype, alignment=None):
        if shape == 0 or alignment is not None:  # dynamic shared memory: one buffer, no key
            return _simulator_shared_array(self, shape, dtype, alignment)
        if isinstance(dtype, _types.Type):
            dtype = numpy_support.as_dtype(dtype)
        frame = sys._getframe(1)
        caller = (frame.f_code.co_filename, frame.f_lineno)
        with _SHARED_LOCK:
            res = self._allocations.get(caller)
            if res is None:
                res = self._allocations[caller] = np.empty(shape, dtype)
        return res

    FakeCUDAShared.array = _shared_array

THREADS = 128
#: the dtype of the sort's indices (cell ids, cell starts, permutation, histogram): unsigned,
#: so that a neighbour index read from the cell starts is too, as on the CPU (Numba then emits
#: no negative-index wrap-around code), and 32-bit, half the bytes of int64 for every index
#: read (a case is refused when its particles or cells do not fit: ``CudaBackend.max_index``)
INDEX = np.uint32
#: the cell-start scan's chunks (the elements a thread scans serially): at least this long,
#: and at most SCAN_CHUNKS many
SCAN_CHUNK = 64
SCAN_CHUNKS = 64 * THREADS


def _blocks(n):
    return max(1, math.ceil(n / THREADS))


_STREAM = []


def _stream():
    """The one stream every launch and copy of the run is queued on (made at the first use):
    an explicit stream, not the legacy default one, so that nothing else a process runs on
    the device is serialised with the step, and work is captured or timed on one queue."""
    if not _STREAM:
        _STREAM.append(cuda.stream())
    return _STREAM[0]


def _read(dev):
    """A device array's values on the host, after every launch queued before (a blocking read)."""
    s = _stream()
    out = dev.copy_to_host(stream=s)
    s.synchronize()
    return out


# ------------------------------------------------------------------ P on the device
#: parameter records in flight: the host waits for the oldest upload only when this many
#: distinct ``P`` have been uploaded since it was (never at a constant step, where P holds)
PARAM_SLOTS = 4


def _record_dtype(P):
    """The record a kernel reads ``P`` (a namedtuple of numbers) from: its fields in order."""
    return np.dtype((np.record, [(f, np.asarray(v).dtype) for f, v in zip(P._fields, P)]), align=True)


def params_record(P):
    """``P`` as a one-record host array (what ``_params`` uploads, and what ``validation.ptx``
    types the kernels with)."""
    a = np.zeros(1, dtype=_record_dtype(P))
    a[0] = tuple(P)
    return a


_LOADERS = {}


def _loader(T):
    """load(Pd) -> T(Pd[0].f0, Pd[0].f1, ...): the record read back into the namedtuple the
    physics takes, so the pair functions compile with the same ``P`` type as on the CPU (its
    fields in registers, as the by-value arguments were; the fields a kernel never reads are
    never loaded)."""
    if T not in _LOADERS:
        ns = {"T": T}
        exec("def load(Pd):\n    r = Pd[0]\n    return T(" + ", ".join(f"r.{f}" for f in T._fields) + ")\n", ns)
        _LOADERS[T] = cuda.jit(device=True)(ns["load"])
    return _LOADERS[T]


def _per_params(build):
    """kernel_of(T): ``build(load)`` for parameter tuples of type T, made the first time one
    comes (one type per launch in practice: the model's ``Params``)."""
    made = {}

    def kernel_of(T):
        k = made.get(T)
        if k is None:
            k = made[T] = build(_loader(T))
        return k

    return kernel_of


class _UploadRing:
    """Uploads of one record type or array shape: each distinct value copied asynchronously
    from a pinned buffer into a device array, on the stream the kernels run on (so an array
    is rewritten only after every launch before it has read it); the host reuses a pinned
    buffer once its last copy has completed (an event). No allocation after the first
    ``PARAM_SLOTS`` uploads."""

    def __init__(self, shape, dtype):
        self.slots = [(cuda.pinned_array(shape, dtype=dtype), cuda.device_array(shape, dtype=dtype), cuda.event())
                      for _ in range(PARAM_SLOTS)]
        self.used = [False] * PARAM_SLOTS
        self.next = 0
        self.last = None  # (values, device array) of the last upload

    def __call__(self, values):
        """The device array holding ``values`` (a record's tuple, or an array of the shape)."""
        same = values if isinstance(values, tuple) else values.tobytes()
        if self.last is not None and self.last[0] == same:
            return self.last[1]
        k = self.next
        self.next = (k + 1) % PARAM_SLOTS
        host, dev, copied = self.slots[k]
        if self.used[k]:
            copied.synchronize()
        if isinstance(values, tuple):
            host[0] = values
        else:
            host[...] = values
        stream = _stream()
        dev.copy_to_device(host, stream=stream)
        copied.record(stream)
        self.used[k] = True
        self.last = (same, dev)
        return dev


_RINGS = {}


def _params(P):
    """``P`` on the device: one array argument for a launch instead of its ~40 numbers by value,
    uploaded only when it changed (an adaptive step's dt; never at a constant step)."""
    _flush_sizing()
    key = (type(P), type(P[0]))
    ring = _RINGS.get(key)
    if ring is None:
        ring = _RINGS[key] = _UploadRing(1, _record_dtype(P))
    return ring(tuple(P))


_BODIES = {}
_SIZERS = {}
#: the sizing ``size_step`` asked for and no launch has made yet: (key, arguments)
_SIZING = [None]


def _size_body(stable, stepped, value):
    """The step's sizing as a device function of one thread: the rule ``stable`` and, for each
    (field, c, power) of ``stepped``, P's field = ``value(c, power, dt)``."""
    key = (stable, stepped, value)
    f = _BODIES.get(key)
    if f is None:
        ns = {"cuda": cuda, "math": math, "rule": cuda.jit(device=True)(stable), "value": cuda.jit(device=True)(value)}
        lines = [f"    Pd[0].{f} = value({c!r}, {power}, dt)" for f, c, power in stepped]
        exec("def size(Pd, ring, last, row, cfl, h, c0, force_cfl, nu):\n"
             "    v2, a2 = ring[last, 0, 0], ring[last, 1, 0]\n"  # a max over no particle: -inf
             "    dt = rule(math.sqrt(v2) if v2 > 0 else 0.0, math.sqrt(a2) if a2 > 0 else 0.0, cfl, h, c0, "
             "force_cfl, nu)\n"
             "    Pd[0].dt = dt\n" + "".join(line + "\n" for line in lines) +
             "    ring[row, 4, 0] = dt\n", ns)
        f = _BODIES[key] = cuda.jit(device=True)(ns["size"])
    return f


def _sizer(stable, stepped, value):
    """The sizing as a launch of its own (``_size_body``, one thread)."""
    key = (stable, stepped, value)
    k = _SIZERS.get(key)
    if k is None:
        body = _size_body(*key)

        @cuda.jit
        def size(Pd, ring, last, row, cfl, h, c0, force_cfl, nu):
            if cuda.grid(1) == 0:
                body(Pd, ring, last, row, cfl, h, c0, force_cfl, nu)

        k = _SIZERS[key] = size
    return k


def _take_sizing():
    """The pending sizing (None if none), no longer pending."""
    sizing, _SIZING[0] = _SIZING[0], None
    return sizing


def _flush_sizing():
    """A pending sizing launched on its own: a launch that reads P is about to be made before
    a sort could make it."""
    sizing = _take_sizing()
    if sizing is not None:
        _sizer(*sizing[0])[1, 1, _stream()](*sizing[1])


@cuda.jit(device=True)
def _cell_of(x, i, origin, inv_cell, nx, ny, nz, ncells, k):
    """The cell of particle i, or ``ncells`` outside the grid's inner cells (the CPU
    backend's ``_cell_ids``)."""
    cx = int(math.floor((x[0, i] - origin[0]) * inv_cell[0]))
    cy = int(math.floor((x[1, i] - origin[1]) * inv_cell[1]))
    inside = k <= cx < nx - k and k <= cy < ny - k
    cz = 0
    if x.shape[0] == 3:
        cz = int(math.floor((x[2, i] - origin[2]) * inv_cell[2]))
        inside = inside and k <= cz < nz - k
    return cx + nx * (cy + ny * cz) if inside else ncells


@cuda.jit(device=True)
def _count(c, count, sums, chunk):
    """Particle in cell c counted in the histogram ``count`` and in its chunk's sum."""
    cuda.atomic.add(count, c, 1)
    cuda.atomic.add(sums, c // chunk, 1)


@cuda.jit
def _cell_ids_counted(x, origin, inv_cell, nx, ny, nz, ncells, k, drop, use_drop, cell, count, sums, chunk):
    """cell[i] = the cell of particle i (``ncells`` outside the grid, or where drop[i] when
    ``use_drop``), counted in the histogram and the chunk sums."""
    i = cuda.grid(1)
    if i < x.shape[1]:
        c = _cell_of(x, i, origin, inv_cell, nx, ny, nz, ncells, k)
        if use_drop and drop[i]:
            c = ncells
        cell[i] = c
        _count(c, count, sums, chunk)


@cuda.jit(device=True)
def _place(k, cell, start, raw, perm):
    """(d, j): the particle j that the scatter put at position k of its cell's range, and its
    place d there in the stable order (how many of the range's indices are smaller than j:
    the CPU's argsort within a cell), written to perm[d]."""
    j = raw[k]
    c = cell[j]
    d = start[c]
    for m in range(start[c], start[c + 1]):
        if raw[m] < j:
            d += 1
    perm[d] = j
    return d, j


@cuda.jit
def _place_cells(cell, start, raw, perm):
    """perm = the stable order of the scattered ``raw`` (``_place``), one thread per particle."""
    k = cuda.grid(1)
    if k < raw.size:
        _place(k, cell, start, raw, perm)


@cuda.jit
def _place_fields(cell, start, raw, perm, groups, n_in):
    """As ``_place_cells``, and each particle placed before ``n_in`` gathered there: dst[c, d] =
    src[c, j] for every (components, particles) field pair of ``groups``, a tuple, one entry
    per dtype, of (sources, destinations), each a tuple of arrays of that dtype (1D fields as
    (1, n) views). One launch orders the cells and moves every field."""
    k = cuda.grid(1)
    if k < raw.size:
        d, j = _place(k, cell, start, raw, perm)
        if d < n_in:
            for g in literal_unroll(groups):
                for f in range(len(g[0])):
                    src = g[0][f]
                    dst = g[1][f]
                    for c in range(src.shape[0]):
                        dst[c, d] = src[c, j]


_PLACE_THEN = {}


def _place_then(fn, T):
    """``_place_fields`` with fn(d, J, P, rho) for each particle placed at d, after its
    fields (J: a view of the set's sorted fields; rho: the density just moved there): the
    model's p and V of the step's first evaluation made in the sort's own launch; ``P`` of
    type T, read from the device (``_params``)."""
    if (fn, T) not in _PLACE_THEN:
        load = _loader(T)

        @cuda.jit
        def run(cell, start, raw, perm, groups, n_in, J, Pd):
            k = cuda.grid(1)
            if k < raw.size:
                d, j = _place(k, cell, start, raw, perm)
                if d < n_in:
                    for g in literal_unroll(groups):
                        for f in range(len(g[0])):
                            src = g[0][f]
                            dst = g[1][f]
                            for c in range(src.shape[0]):
                                dst[c, d] = src[c, j]
                    fn(d, J, load(Pd), J.rho[d])

        _PLACE_THEN[(fn, T)] = run
    return _PLACE_THEN[(fn, T)]


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
def _body_sums(x, load, body, rows, refs, out):
    """One block per entry (r, comp) of out (bodies, 6): its threads sum body_term over the
    wall points of row r in a fixed stride and reduce in shared memory (the same order every
    launch: no atomics, so a body's motion repeats bit for bit)."""
    r = cuda.blockIdx.x // 6
    comp = cuda.blockIdx.x % 6
    t = cuda.threadIdx.x
    tile = cuda.shared.array(THREADS, dtype=np.float64)
    s = 0.0
    i = t
    while i < body.size:
        b = body[i]
        if b >= 0 and b < rows.size and rows[b] == r:
            s += body_term(x, load, refs, i, r, comp)
        i += THREADS
    _block_tree(tile, s, False, r, out, comp)


@cuda.jit
def _histogram(cell, count, sums, chunk):
    i = cuda.grid(1)
    if i < cell.size:
        _count(cell[i], count, sums, chunk)


@cuda.jit
def _zero(a):
    i = cuda.grid(1)
    if i < a.size:
        a[i] = 0


@cuda.jit
def _scan_chunks(a, chunk, sums, out, fill, ticket):
    """The scan of the sort (``_scan_body``), one launch."""
    _scan_body(a, chunk, sums, out, fill, ticket)


_SCANS = {}


def _scan_sized(key):
    """The sort's scan launched with the step's sizing (``size_step``) in its first thread:
    one launch for both. ``key``: the sizing's (rule, stepped fields, value function)."""
    k = _SCANS.get(key)
    if k is None:
        body = _size_body(*key)

        @cuda.jit
        def scan_sized(a, chunk, sums, out, fill, ticket, Pd, ring, last, row, cfl, h, c0, force_cfl, nu):
            if cuda.grid(1) == 0:
                body(Pd, ring, last, row, cfl, h, c0, force_cfl, nu)
            _scan_body(a, chunk, sums, out, fill, ticket)

        k = _SCANS[key] = scan_sized
    return k


@cuda.jit(device=True)
def _scan_body(a, chunk, sums, out, fill, ticket):
    """out[k] = fill[k] = the sum of a[:k] (exclusive), thread t of block b scanning chunk
    c = b * THREADS + t (a[c chunk:(c + 1) chunk], whose sum is sums[c]) from the sum of the
    chunks before it: the chunk sums before the block's first (summed by the block's
    threads) plus the block's own up to c (a scan in shared memory). a and sums are left
    zero (the histogram and its chunk sums, consumed: the next sort counts from zero; the
    last block to have read the sums zeroes them, and resets ``ticket``). Launch with
    THREADS threads per block and one thread per chunk."""
    tile = cuda.shared.array(THREADS, dtype=np.int64)
    last = cuda.shared.array(1, dtype=np.int64)
    t = cuda.threadIdx.x
    first = cuda.blockIdx.x * THREADS
    s = 0
    m = t
    while m < first:
        s += sums[m]
        m += THREADS
    tile[t] = s
    cuda.syncthreads()
    step = THREADS // 2
    while step > 0:
        if t < step:
            tile[t] += tile[t + step]
        cuda.syncthreads()
        step //= 2
    base = tile[0]
    cuda.syncthreads()
    c = first + t
    own = sums[c] if c < sums.size else 0
    tile[t] = own
    cuda.syncthreads()
    d = 1
    while d < THREADS:  # inclusive scan of the block's chunk sums (Hillis & Steele)
        v = tile[t - d] if t >= d else 0
        cuda.syncthreads()
        tile[t] += v
        cuda.syncthreads()
        d *= 2
    if t == 0:  # every read of the sums is done in this block (the barrier above)
        last[0] = 1 if cuda.atomic.add(ticket, 0, 1) == cuda.gridDim.x - 1 else 0
    cuda.syncthreads()
    if last[0] == 1:
        m = t
        while m < sums.size:
            sums[m] = 0
            m += THREADS
        if t == 0:
            ticket[0] = 0
    if c < sums.size:
        s = base + tile[t] - own
        for k in range(c * chunk, min((c + 1) * chunk, a.size)):
            out[k] = s
            fill[k] = s
            s += a[k]
            a[k] = 0


@cuda.jit
def _scatter_cells(cell, fill, raw):
    """raw[fill[c]++] = i for particle i of cell c: each cell's particles in its range, in
    the order the atomics give."""
    i = cuda.grid(1)
    if i < cell.size:
        raw[cuda.atomic.add(fill, cell[i], 1)] = i


_SCRATCH = {}


def _scratch(shape, dtype=np.float64):
    """A device array for a result that is reduced before the call that asked returns (kept
    per shape: no allocation per step)."""
    key = (shape, np.dtype(dtype))
    if key not in _SCRATCH:
        _SCRATCH[key] = cuda.device_array(shape, dtype=dtype)
    return _SCRATCH[key]


def _buffer(work, name, n):
    """The ``INDEX`` device array ``name`` of length n from the dict ``work``, allocated (zero)
    once."""
    a = work.get(name)
    if a is None or a.size != n:
        a = work[name] = cuda.to_device(np.zeros(n, dtype=INDEX))
    return a


def _sort_buffers(work, ncells):
    """(count, sums, chunk, ticket) of the dict ``work``: the histogram of ncells + 2 cells,
    its sums over chunks of ``chunk`` cells, the scan's last-block ticket; allocated zero once
    per grid size, and left zero by each sort. The chunks are at least SCAN_CHUNK long and at
    most SCAN_CHUNKS many, which bounds the scan's work (each block sums the chunk sums before
    it)."""
    m = ncells + 2
    chunk = max(SCAN_CHUNK, math.ceil(m / SCAN_CHUNKS))
    return _buffer(work, "count", m), _buffer(work, "sums", math.ceil(m / chunk)), chunk, _buffer(work, "ticket", 1)


def _scan_scatter(cell, ncells, work, counted=False):
    """(raw, start) for cell ids in [0, ncells] (ncells: outside the grid): start[c] the first
    position of cell c, start[ncells + 1] = n, and raw each cell's particle indices in its
    range in the order the scatter's atomics gave them (``_place_cells`` or ``_place_fields``
    put them in the stable order). All on the device, in the buffers of the dict ``work`` (one
    per particle set: its ``start`` and ``_perm`` are these). ``counted``: the histogram and
    its chunk sums (``_sort_buffers``) are already made (``_cell_ids_counted`` or the check);
    they are zero after the call."""
    n = cell.size
    count, sums, chunk, ticket = _sort_buffers(work, ncells)
    if n and not counted:
        _histogram[_blocks(n), THREADS, _stream()](cell, count, sums, chunk)
    start = _buffer(work, "start", ncells + 2)
    fill = _buffer(work, "fill", ncells + 2)
    sizing = _take_sizing()
    if sizing is None:
        _scan_chunks[_blocks(sums.size), THREADS, _stream()](count, chunk, sums, start, fill, ticket)
    else:  # the step's size, made in the same launch (before any launch reads P)
        _scan_sized(sizing[0])[_blocks(sums.size), THREADS, _stream()](count, chunk, sums, start, fill, ticket, *sizing[1])
    raw = _buffer(work, "raw", n)
    if n:
        _scatter_cells[_blocks(n), THREADS, _stream()](cell, fill, raw)
    return raw, start


def _counting_sort(cell, ncells, work, counted=False):
    """(perm, start): perm the stable order by cell (new position -> old index), start as
    ``_scan_scatter``'s."""
    raw, start = _scan_scatter(cell, ncells, work, counted)
    perm = _buffer(work, "perm", cell.size)
    if cell.size:
        _place_cells[_blocks(cell.size), THREADS, _stream()](cell, start, raw, perm)
    return perm, start


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


#: the x at which a particle that left the grid waits for the host to drop it
#: (``CudaBackend.check_later``): finite, far beyond any grid, so that it cannot walk back in
PARKED = 1.0e30


def _pass_body(dim, init, pair1, pair2, finish, use2, zero, periodic=None, keep=None):
    """body(i, I, J1, J2, P, G): particle i's walk over the cells around it and its
    ``finish``, the same walk as the CPU backend's (a device function of the pass kernels and
    of a tail's wall corrections); with ``keep``, only for the i that keep(i, I, P) holds."""
    sift = keep is not None  # a constant of the compiled kernel: without keep, no test at all
    keep = every if keep is None else keep
    visit1 = make_run_visitor(dim, pair1, zero)
    visit2 = make_run_visitor(dim, pair2, zero)
    if periodic is not None and any(periodic):
        walk = make_periodic_walk(dim, visit1, visit2, use2, zero, periodic)

        @cuda.jit(device=True)
        def body_periodic(i, I, J1, J2, P, G):
            if I.cell[i] >= G.ncells:  # parked (``body`` below)
                I.x[0, i] = PARKED
                return
            if sift and not keep(i, I, P):
                return
            zi = I.x[2, i] if dim == 3 else zero
            acc = walk(i, I.x[0, i], I.x[1, i], zi, I.cell[i], I, J1, J2, P, G, init(i, I, P))
            finish(i, I, P, acc)

        return body_periodic

    @cuda.jit(device=True)
    def body(i, I, J1, J2, P, G):
        c = I.cell[i]
        if c >= G.ncells:  # left the grid since a check the host has not read yet: parked
            I.x[0, i] = PARKED
            return
        if sift and not keep(i, I, P):
            return
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

    return body


def _make_pass_kernel(dim, init, pair1, pair2, finish, use2, zero, periodic=None, then=None, keep=None):
    """The one CUDA neighbour loop, one thread per i. ``then``: then(i, I, S, R, P) after
    i's ``finish``, in the same thread (launched with (S, R) after the pass's arguments).

    The kernel takes the views it reads once: a view passed twice costs numba-cuda's
    dispatcher its arrays twice (about a hundred scalars for the fluid's), so J1 is left out
    when it is I (the fluid's own passes), J2 when the pass has no second set; T, the tuple
    of ``then``'s views, is empty without it."""
    body = _pass_body(dim, init, pair1, pair2, finish, use2, zero, periodic, keep)
    if then is None:
        @cuda.jit(device=True)
        def after(i, I, T, P):
            pass
    else:
        @cuda.jit(device=True)
        def after(i, I, T, P):
            then(i, I, T[0], T[1], P)

    def build(load):
        @cuda.jit(device=True)
        def one(I, J1, J2, Pd, G, T):
            i = cuda.grid(1)
            if i < I.x.shape[1]:
                P = load(Pd)
                body(i, I, J1, J2, P, G)
                after(i, I, T, P)

        @cuda.jit
        def self1(I, Pd, G, T):
            one(I, I, I, Pd, G, T)

        @cuda.jit
        def other1(I, J1, Pd, G, T):
            one(I, J1, J1, Pd, G, T)

        @cuda.jit
        def self2(I, J2, Pd, G, T):
            one(I, I, J2, Pd, G, T)

        @cuda.jit
        def other2(I, J1, J2, Pd, G, T):
            one(I, J1, J2, Pd, G, T)

        return {(True, False): self1, (False, False): other1, (True, True): self2, (False, True): other2}

    kernels_of = _per_params(build)

    def kernel_for(I, J1, J2, P, G, S=None, R=None, upload=_params):
        """The kernel for these views and its arguments (``upload``: P's form as an argument,
        the device record by default)."""
        same = J1 is I
        args = (I,) + (() if same else (J1,)) + ((J2,) if use2 else ()) + (upload(P), G,
                                                                            () if then is None else (S, R))
        return kernels_of(type(P))[(same, use2)], args

    def launch(I, J1, J2, P, G, S=None, R=None):
        n = I.x.shape[1]
        if n:
            run, args = kernel_for(I, J1, J2, P, G, S, R)
            run[_blocks(n), THREADS, _stream()](*args)

    launch.kernel_for = kernel_for  # what ``validation.ptx`` compiles
    return launch


def _make_map_kernel(fn):
    def build(load):
        @cuda.jit
        def run(I, Pd):
            i = cuda.grid(1)
            if i < I.x.shape[1]:
                fn(i, I, load(Pd))

        return run

    kernel_of = _per_params(build)

    def launch(I, P):
        n = I.x.shape[1]
        if n:
            kernel_of(type(P))[_blocks(n), THREADS, _stream()](I, _params(P))

    launch.kernel_of = kernel_of
    return launch


def _make_fused_map_kernel(fn, then):
    def build(load):
        @cuda.jit
        def run(I, Pd, J):
            i = cuda.grid(1)
            if i < I.x.shape[1]:
                P = load(Pd)
                fn(i, I, P)
                then(i, J, P, I.rho[i])

        return run

    kernel_of = _per_params(build)

    def launch(I, P, J):
        n = I.x.shape[1]
        if n:
            kernel_of(type(P))[_blocks(n), THREADS, _stream()](I, _params(P), J)

    launch.kernel_of = kernel_of
    return launch


def _make_tail_kernel(dim, fn, walk, zero):
    """The step's last map fn(i, I, P) and, in the same loop, what the run puts after it
    (``backend.make_tail``): with ``walk`` = (init, pair, finish), the pass of particle i of
    the view F over the set J (the wall corrections: each particle's own state and its wall
    neighbours, nothing another thread writes); with ``measure`` the check of particle i
    after both, reduced as ``_check_blocks`` reduces it (in the same blocks: one thread per
    particle), with the next sort's cell ids, histogram and chunk sums."""
    if walk is None:
        @cuda.jit(device=True)
        def after(i, F, J, P, G):
            pass
    else:
        body = _pass_body(dim, walk[0], walk[1], walk[1], walk[2], False, zero)

        @cuda.jit(device=True)
        def after(i, F, J, P, G):
            body(i, F, J, J, P, G)

    def build(load):
        @cuda.jit
        def run(I, Pd, F, J, G, measure, origin, inv_cell, nx, ny, nz, ncells, k, is_max, partial, final,
                counter, cell, count, sums, chunk):
            tile = cuda.shared.array(THREADS, dtype=np.float64)
            i = cuda.grid(1)
            n = I.x.shape[1]
            if i < n:
                P = load(Pd)
                fn(i, I, P)
                after(i, F, J, P, G)
            if measure:  # the same for every thread: the barriers below are reached by all
                acc = (0.0, 0.0, 0.0, 0.0)
                if i < n:
                    acc = _check_one(I.x, I.v, I.dvdt, i, acc, origin, inv_cell, nx, ny, nz, ncells, k, True, cell,
                                     count, sums, chunk)
                _check_reduce(tile, acc, is_max, partial, final, counter)

        return run

    kernel_of = _per_params(build)

    def launch(I, P, F=None, J=None, G=None, measure=None):
        """``measure``: (the particle set of I, its grid) to check in the same launch."""
        n = I.x.shape[1]
        if not n:
            return
        if F is None:
            F, J, G = I, I, _unused(np.int8)
        nb = _blocks(n)
        run = kernel_of(type(P))
        if measure is None:
            run[nb, THREADS, _stream()](I, _params(P), F, J, G, False, *_no_measure(I.x.dtype))
            return
        pset, grid = measure
        args = _measure_args(pset, grid, nb)
        run[nb, THREADS, _stream()](I, _params(P), F, J, G, True, *args)
        pset.__dict__["_counted"] = (pset["x"], n, grid)
        pset.__dict__["_measured"] = (pset["x"], n, args[9])

    launch.kernel_of = kernel_of
    return launch


def _make_reduce_kernel(fn):
    def build(load):
        @cuda.jit
        def run(I, Pd, out):
            i = cuda.grid(1)
            if i < I.x.shape[1]:
                a, b, c = fn(i, I, load(Pd))
                out[0, i] = a
                out[1, i] = b
                out[2, i] = c

        return run

    kernel_of = _per_params(build)

    def launch(I, P, owned=None):
        n = I.x.shape[1]
        if n == 0:
            return 0.0, 0.0, 0.0
        out = _scratch((3, n))
        kernel_of(type(P))[_blocks(n), THREADS, _stream()](I, _params(P), out)
        return _reduce_rows(out, ("sum", "sum", "max"), owned)

    launch.kernel_of = kernel_of
    return launch


@cuda.jit(device=True)
def _block_tree(tile, acc, is_max, r, out, col):
    """out[r, col] = the block's threads' ``acc`` reduced (max or sum) in the shared array
    ``tile``."""
    t = cuda.threadIdx.x
    tile[t] = acc
    cuda.syncthreads()
    step = THREADS // 2
    while step > 0:
        if t < step:
            tile[t] = max(tile[t], tile[t + step]) if is_max else tile[t] + tile[t + step]
        cuda.syncthreads()
        step //= 2
    if t == 0:
        out[r, col] = tile[0]
    cuda.syncthreads()


@cuda.jit(device=True)
def _finish_if_last(tile, partial, is_max, final, counter):
    """After every block wrote its column of ``partial``: the last block to get here reduces
    the columns into final[r, 0] (sum, or max where is_max[r]) and resets ``counter`` for the
    next launch. The reduction's second level in the same launch."""
    t = cuda.threadIdx.x
    last = cuda.shared.array(1, dtype=np.int64)
    cuda.threadfence()  # this block's partial results visible to the others before its ticket
    if t == 0:
        last[0] = 1 if cuda.atomic.add(counter, 0, 1) == cuda.gridDim.x - 1 else 0
    cuda.syncthreads()
    if last[0] == 1:
        for r in range(partial.shape[0]):
            acc = -math.inf if is_max[r] else 0.0
            m = t
            while m < cuda.gridDim.x:
                acc = max(acc, partial[r, m]) if is_max[r] else acc + partial[r, m]
                m += THREADS
            _block_tree(tile, acc, is_max[r], r, final, 0)
        if t == 0:
            counter[0] = 0


@cuda.jit
def _reduce_blocks(out, is_max, mask, masked, partial, final, counter):
    """final[r, 0]: row r of ``out`` reduced (sum, or max where is_max[r]) over its columns
    (those with mask[i] != 0 only, when ``masked``): each block its grid-stride share into
    partial[r, block], the last block those."""
    tile = cuda.shared.array(THREADS, dtype=np.float64)
    n = out.shape[1]
    for r in range(out.shape[0]):
        acc = -math.inf if is_max[r] else 0.0
        i = cuda.grid(1)
        while i < n:
            if not masked or mask[i] != 0:
                v = out[r, i]
                acc = max(acc, v) if is_max[r] else acc + v
            i += cuda.gridsize(1)
        _block_tree(tile, acc, is_max[r], r, partial, cuda.blockIdx.x)
    _finish_if_last(tile, partial, is_max, final, counter)


@cuda.jit(device=True)
def _check_one(x, v, a, i, acc, origin, inv_cell, nx, ny, nz, ncells, k, count_cells, cell, count, sums, chunk):
    """``acc`` = (largest |v|^2, largest |a|^2, particles with anything non-finite, particles
    outside the grid) with particle i checked in; with ``count_cells`` also its cell id
    written and counted for the next sort (``_cell_ids_counted``). A particle parked beyond
    the grid (left at an earlier step, waiting for the host to drop it) counts as outside
    only: the CPU has dropped it, so that the speeds (and a step sized from them) are the
    CPU's."""
    vmax2, amax2, bad, outside = acc
    if not x[0, i] >= 0.5 * PARKED:  # (PARKED as stored in float32 is not PARKED; NaN is not parked)
        s, q, ok = particle_check(x, v, a, i)
        if ok:
            vmax2 = max(vmax2, s)
            amax2 = max(amax2, q)
        else:
            bad += 1.0
    c = _cell_of(x, i, origin, inv_cell, nx, ny, nz, ncells, k)
    if c == ncells:
        outside += 1.0
    if count_cells:
        cell[i] = c
        _count(c, count, sums, chunk)
    return vmax2, amax2, bad, outside


@cuda.jit(device=True)
def _check_reduce(tile, acc, is_max, partial, final, counter):
    """The threads' ``_check_one`` figures reduced into final[:, 0] (the last block reduces
    the blocks' columns of ``partial``); every thread of the launch must reach it."""
    b = cuda.blockIdx.x
    _block_tree(tile, acc[0], True, 0, partial, b)
    _block_tree(tile, acc[1], True, 1, partial, b)
    _block_tree(tile, acc[2], False, 2, partial, b)
    _block_tree(tile, acc[3], False, 3, partial, b)
    _finish_if_last(tile, partial, is_max, final, counter)


@cuda.jit
def _check_blocks(x, v, a, origin, inv_cell, nx, ny, nz, ncells, k, mask, masked, is_max, partial, final, counter,
                  count_cells, cell, count, sums, chunk):
    """The check's figures, reduced in one launch: final[:, 0] = (largest |v|^2, largest
    |a|^2, particles with anything non-finite, particles outside the grid) (owned ones only,
    when ``masked``); ``is_max`` the rows' ops (max, max, sum, sum). With ``count_cells``
    (every particle checked) also the next sort's cell ids, histogram and chunk sums
    (``_cell_ids_counted``)."""
    tile = cuda.shared.array(THREADS, dtype=np.float64)
    acc = (0.0, 0.0, 0.0, 0.0)
    i = cuda.grid(1)
    while i < x.shape[1]:
        if not masked or mask[i] != 0:
            acc = _check_one(x, v, a, i, acc, origin, inv_cell, nx, ny, nz, ncells, k, count_cells, cell, count,
                             sums, chunk)
        i += cuda.gridsize(1)
    _check_reduce(tile, acc, is_max, partial, final, counter)


#: blocks of the first reduction level (their partial results are reduced by the last block)
REDUCE_BLOCKS = 128
_OPS = {}  # the rows' ops as device flags, per tuple of ops


def _flags(ops):
    """The rows' ops as device flags (1: max), uploaded once per tuple of ops."""
    if ops not in _OPS:
        _OPS[ops] = cuda.to_device(np.array([op == "max" for op in ops], dtype=np.int8))
    return _OPS[ops]


def _mask(owned):
    """The columns to reduce over as a device array (a placeholder when all are)."""
    if owned is None:
        return _unused(np.int8)
    return owned if hasattr(owned, "copy_to_host") else cuda.to_device(np.ascontiguousarray(owned))


def _unused(dtype):
    """A one-element device array of ``dtype`` for an argument a launch does not read
    (uploaded once per dtype)."""
    key = ("unused", np.dtype(dtype).str)
    if key not in _OPS:
        _OPS[key] = cuda.to_device(np.zeros(1, dtype=dtype))
    return _OPS[key]


def _counter():
    """The last-block counter of the reductions (zero between launches: the last block resets
    it), allocated once."""
    if "counter" not in _OPS:
        _OPS["counter"] = cuda.to_device(np.zeros(1, dtype=np.int64))
    return _OPS["counter"]


def _row_values(r, ops):
    """Reduced rows as host floats (a max over no column: 0)."""
    return tuple(0.0 if (op == "max" and v == -math.inf) else float(v) for v, op in zip(r, ops))


def _rows_to_host(final, ops):
    """The reduced rows copied to the host (``_row_values``)."""
    return _row_values(_read(final)[:, 0], ops)


def _reduce_rows(out, ops, owned=None):
    """Each row of a (rows, n) float64 device array reduced by its op ("sum" or "max") on the
    device, over the columns with ``owned[i]`` when given (a process of a decomposed run skips
    its ghost copies); the rows' results (a max over no column: 0) copied to the host."""
    rows, n = out.shape
    if n == 0:
        return (0.0,) * rows
    nb = min(REDUCE_BLOCKS, _blocks(n))
    partial, final = _scratch((rows, nb)), _scratch((rows, 1))
    _reduce_blocks[nb, THREADS, _stream()](out, _flags(ops), _mask(owned), owned is not None, partial, final, _counter())
    return _rows_to_host(final, ops)


def _wrap_constants(grid, dt):
    """The periodic wrap's constants of ``grid`` in dtype ``dt`` as device arrays, uploaded once
    (the wrap runs every step): the box's lower corner and lengths, the inverse cell size,
    the origin, the real cells per axis and the periodic axes."""
    cache = grid.__dict__.setdefault("_device_wrap", {})
    if dt not in cache:
        lo, length = grid.lengths()
        origin, inv = grid.geometry(dt)
        axes = np.array([a for a in range(grid.dim) if grid.periodic[a]], dtype=np.int64)
        real = np.asarray(grid.shape[: grid.dim], dtype=np.int64) - 2 * grid.reach
        cache[dt] = tuple(cuda.to_device(np.ascontiguousarray(a))
                          for a in (lo.astype(dt), length.astype(dt), inv, origin, real, axes))
    return cache[dt]


def _on_device(grid, dt):
    """The grid's origin and inverse cell size in dtype ``dt`` as device arrays, uploaded once."""
    cache = grid.__dict__.setdefault("_device_geometry", {})
    if dt not in cache:
        cache[dt] = tuple(cuda.to_device(a) for a in grid.geometry(dt))
    return cache[dt]


#: the check's rows: largest |v|^2, largest |a|^2, non-finite particles, particles outside
CHECK_OPS = ("max", "max", "sum", "sum")
_NO_MEASURE = {}  # the tail kernel's check arguments when it does not check, per dtype


def _measure_args(pset, grid, nb):
    """The check's arguments after the per-particle arrays, for ``nb`` blocks: the grid's
    constants (none: every particle counts as inside), the rows' ops, the partial and final
    results and the last-block counter, then the next sort's cell ids, histogram, chunk sums
    and chunk length (placeholders without a grid)."""
    x = pset["x"]
    dt = np.dtype(x.dtype).type
    if grid is None:
        origin = inv = _unused_vector(dt)
        nx = ny = nz = ncells = k = 2 ** 40  # no cell is out of range
        cell = count = sums = _unused(INDEX)
        chunk = 1
    else:
        g = grid.view()
        origin, inv = _on_device(grid, dt)
        nx, ny, nz, ncells, k = g.nx, g.ny, g.nz, g.ncells, g.k
        work = pset.__dict__.setdefault("_sort_work", {})
        count, sums, chunk, _ = _sort_buffers(work, ncells)
        cell = work.get("cell")
        if cell is None or cell.shape[0] != pset.n:
            cell = work["cell"] = cuda.device_array(pset.n, dtype=INDEX)
    return (origin, inv, nx, ny, nz, ncells, k, _flags(CHECK_OPS), _scratch((4, nb)), _ring_row(pset), _counter(),
            cell, count, sums, chunk)


def _ring_row(pset):
    """Where the check of ``pset`` reduces its four figures: the row of the checks' ring the
    next ``check_later`` fills (no copy into it then), else a scratch array."""
    row = pset.__dict__.get("_into_row")
    if row is None:
        return _scratch((4, 1))
    return pset.__dict__["_ring"][row, :4]


def _unused_vector(dt):
    key = ("vector", np.dtype(dt).str)
    if key not in _OPS:
        _OPS[key] = cuda.to_device(np.zeros(3, dtype=dt))
    return _OPS[key]


def _no_measure(dt):
    """``_measure_args`` of a tail that does not check (never read)."""
    key = np.dtype(dt).str
    if key not in _NO_MEASURE:
        u = _unused(INDEX)
        _NO_MEASURE[key] = (_unused_vector(dt), _unused_vector(dt), 1, 1, 1, 1, 1, _flags(CHECK_OPS),
                            _scratch((4, 1)), _scratch((4, 1)), _counter(), u, u, u, 1)
    return _NO_MEASURE[key]


class CudaBackend:
    name = "cuda"
    #: the most particles in a set, and cells in a grid (with its two extra ids), that the
    #: sort's ``INDEX`` indices address
    max_index = int(np.iinfo(INDEX).max)

    def to_device(self, a):
        return cuda.to_device(np.ascontiguousarray(a))

    def to_host(self, a):
        return _read(a) if hasattr(a, "copy_to_host") else np.asarray(a)

    def make_pass(self, dim, dtype, init, pair1, finish, pair2=None, cache=True, branchless=False,
                  periodic=None, then=None, parts=None, keep=None):
        """Same interface as the CPU backend; ``cache`` has no effect (kernels compile per
        process), nor ``branchless`` (a thread that skips a pair frees its warp's lane: the
        branch is the faster form on a GPU); ``then`` runs in the pass's own launch
        (``parts`` unused)."""
        use2 = pair2 is not None
        return _make_pass_kernel(dim, init, pair1, pair2 if use2 else pair1, finish, use2,
                                 np.dtype(dtype).type(0), periodic, then, keep)

    def wrap(self, pset, grid):
        if not grid.any_periodic or not pset.n:
            return
        x = pset["x"]
        dt = np.dtype(x.dtype).type
        lo, length, inv, origin, real, axes = _wrap_constants(grid, dt)
        _wrap[_blocks(pset.n), THREADS, _stream()](x, lo, length, inv, origin, grid.reach, real, axes)

    def make_map(self, fn, then=None):
        return _make_map_kernel(fn) if then is None else _make_fused_map_kernel(fn, then)

    def make_reduce(self, fn):
        return _make_reduce_kernel(fn)

    #: a tail (``make_tail``) runs the check in its launch when asked
    fuses_check = True

    def make_tail(self, dim, dtype, fn, walk=None, parts=None):
        """As the CPU backend's ``make_tail``, in one launch (``parts`` unused); called with
        ``measure`` = (the set, its grid), the launch also checks the particles after the map
        and the walk (``check`` then reads its figures, and the next sort its cell counts)."""
        return _make_tail_kernel(dim, fn, walk, np.dtype(dtype).type(0))

    def sort(self, pset, grid, drop=None, refresh=None, inside=False):
        """As the CPU backend's ``sort`` (``drop``: a device array of flags); ``refresh`` in
        the launch that moves the fields (``_place_then``). With ``inside`` (the caller
        knows every particle is in the grid: the moving walls' bounds) the count is not read
        back."""
        g = grid.view()
        x = pset["x"]
        n = pset.n
        origin, inv_cell = _on_device(grid, np.dtype(x.dtype).type)
        work = pset.__dict__.setdefault("_sort_work", {})
        count, sums, chunk, _ = _sort_buffers(work, g.ncells)
        counted = pset.__dict__.pop("_counted", None)  # (x, n, grid) whose cells the check counted
        if counted is not None and drop is None and counted[0] is x and counted[1] == n and counted[2] is grid:
            # the cell ids, in the set's spare cell array, swap with the last sort's
            work["cell"], pset["cell"] = pset["cell"], work["cell"]
        else:
            if counted is not None:  # counted for positions that have changed since
                _zero[_blocks(count.size), THREADS, _stream()](count)
                _zero[_blocks(sums.size), THREADS, _stream()](sums)
            if "cell" not in pset.arrays or pset["cell"].shape[0] != n:
                pset["cell"] = cuda.device_array(n, dtype=INDEX)
            if n:
                _cell_ids_counted[_blocks(n), THREADS, _stream()](x, origin, inv_cell, g.nx, g.ny, g.nz, g.ncells, g.k,
                                                       _unused(np.uint8) if drop is None else drop, drop is not None,
                                                       pset["cell"], count, sums, chunk)
        cell = pset["cell"]
        raw, start_d = _scan_scatter(cell, g.ncells, work, counted=True)
        perm = _buffer(work, "perm", n)
        stays = pset.__dict__.get("_stays")
        pset.__dict__["_stays"] = None
        pset.__dict__["_grid"] = grid
        if drop is None and (inside or stays is not None and stays[0] is x and stays[1] == n and stays[2] is grid):
            n_in = n  # the last check (or the caller) found these positions inside the grid: no read
        else:
            n_in = int(_read(start_d[g.ncells:g.ncells + 1])[0])
        pset["start"] = start_d
        pset["_perm"] = perm  # new position -> old (a decomposed run maps its halo lists through it)
        dropped = n - n_in
        fields = pset.sorted_fields()
        scratch = [k for k in pset.per_particle() if k not in fields]
        # the first n_in of the new order (the dropped ones are sorted last), gathered into
        # the set's spare copy of each field, which then swaps with it (ping-pong: no
        # allocation while the count holds), in the launch that puts each cell in order
        spare = pset.__dict__.setdefault("_spare", {})
        groups = {}  # (sources, destinations) by dtype, as (components, particles) views
        for k in fields:
            a = pset[k]
            out = spare.get(k)
            if out is None or out.shape != a.shape[:-1] + (n_in,) or out.dtype != a.dtype:
                out = cuda.device_array(a.shape[:-1] + (n_in,), dtype=a.dtype)
            if n_in:
                src, dst = groups.setdefault(a.dtype.str, ([], []))
                comps = int(np.prod(a.shape[:-1]))
                src.append(a.reshape(comps, n))
                dst.append(out.reshape(comps, n_in))
            pset[k] = out
            spare[k] = a
        if dropped:
            for k in scratch:  # written before they are read: only their size matters
                pset[k] = cuda.device_array(pset[k].shape[:-1] + (n_in,), dtype=pset[k].dtype)
            pset.n = n_in
        pairs = tuple((tuple(a), tuple(b)) for a, b in groups.values())
        if n_in and refresh is not None:
            fn, _, view, P = refresh
            _place_then(fn, type(P))[_blocks(n), THREADS, _stream()](cell, start_d, raw, perm, pairs, n_in, view(pset),
                                                          _params(P))
        elif n_in:
            _place_fields[_blocks(n), THREADS, _stream()](cell, start_d, raw, perm, pairs, n_in)
        elif n:
            _place_cells[_blocks(n), THREADS, _stream()](cell, start_d, raw, perm)
        return dropped

    def take(self, a, idx):
        """a[..., idx] on the host (a halo's send buffer, staged through the host); ``idx``
        a device array of int64."""
        n = idx.size
        flat = a.reshape(-1, a.shape[-1]) if a.ndim > 2 else a
        out = cuda.device_array(flat.shape[:-1] + (n,), dtype=a.dtype)
        if n:
            (_gather1 if flat.ndim == 1 else _gather2)[_blocks(n), THREADS, _stream()](flat, idx, out)
        return _read(out).reshape(a.shape[:-1] + (n,))

    def put(self, a, idx, values):
        """a[..., idx] = values (host), in place on the device."""
        n = idx.size
        if not n:
            return
        flat = a.reshape(-1, a.shape[-1]) if a.ndim > 2 else a
        src = cuda.to_device(np.ascontiguousarray(values.reshape(flat.shape[:-1] + (n,))))
        (_scatter1 if flat.ndim == 1 else _scatter2)[_blocks(n), THREADS, _stream()](src, idx, flat)

    def index(self, idx):
        return cuda.to_device(np.ascontiguousarray(idx, dtype=np.int64))

    def stage(self, name, a):
        """A small host array (a few numbers that change each call, e.g. the moving bodies'
        poses) on the device for the launches after it: copied asynchronously from pinned
        memory into one of a few device arrays kept under ``name`` (no allocation, no wait)."""
        a = np.ascontiguousarray(a)
        key = (name, a.shape, a.dtype.str)
        ring = _RINGS.get(key)
        if ring is None:
            ring = _RINGS[key] = _UploadRing(a.shape, a.dtype)
        return ring(a)

    def body_sums(self, x, load, body, rows, refs):
        """As the CPU backend's ``body_sums``, reduced on the device: the host reads the
        (bodies, 6) sums, not the walls' positions, loads and body ids (``rows`` uploaded
        once per value, ``refs`` staged)."""
        nb = len(refs)
        key = ("body_sums", nb)
        out = self.__dict__.get(key)
        if out is None:
            out = self.__dict__[key] = cuda.device_array((nb, 6), dtype=np.float64)
        rows_d = self.stage("body_rows", np.ascontiguousarray(rows, dtype=np.int64))
        refs_d = self.stage("body_refs", np.ascontiguousarray(refs, dtype=np.float64))
        _body_sums[6 * nb, THREADS, _stream()](x, load, body, rows_d, refs_d, out)
        return _read(out)

    def check(self, pset, owned=None):
        """As the CPU backend's ``check``. In the same reduction, and the same copy to the
        host, the particles outside the grid of the set's last sort are counted: when there
        are none, the next sort (of these positions) knows its count without asking the
        device."""
        n = pset.n
        pset.__dict__["_stays"] = None
        if n == 0:
            return 0.0, 0.0, 0
        grid = pset.__dict__.get("_grid")
        if grid is None:  # not sorted yet: every particle counts as inside, and nothing is promised
            vmax2, amax2, bad, _ = self._check(pset, owned, None)
            return vmax2, amax2, bad
        vmax2, amax2, bad, outside = self._check(pset, owned, grid)
        if outside == 0 and owned is None:
            pset.__dict__["_stays"] = (pset["x"], n, grid)  # held, not by id: no reuse of a freed id
        return vmax2, amax2, bad

    @classmethod
    def _check(cls, pset, owned, grid):
        vmax2, amax2, bad, outside = _rows_to_host(cls._final(pset, owned, grid), CHECK_OPS)
        return vmax2, amax2, int(bad), int(outside)

    @staticmethod
    def _final(pset, owned, grid):
        """The check's reduction, left on the device (a (4, 1) array); with every particle
        checked (``owned`` None) on a known grid, it counts the cells of the set's next sort
        too (``_counted``). A tail that measured these positions (``make_tail``) left its
        figures: no launch then."""
        n = pset.n
        x = pset["x"]
        measured = pset.__dict__.pop("_measured", None)
        if measured is not None and measured[0] is x and measured[1] == n and owned is None:
            return measured[2]
        nb = min(REDUCE_BLOCKS, _blocks(n))
        args = _measure_args(pset, grid if owned is None else None, nb)
        _check_blocks[nb, THREADS, _stream()](x, pset["v"], pset["dvdt"], *args[:7], _mask(owned), owned is not None,
                                   *args[7:11], grid is not None and owned is None, *args[11:])
        if grid is not None and owned is None:
            pset.__dict__["_counted"] = (x, n, grid)
        return args[9]

    #: ``check_later``, ``start_read`` and ``finish_read``: the host may read the check every few steps
    defers_check = True

    def check_later(self, pset, row, rows):
        """The check of ``pset`` (not empty, every particle its own) into row ``row`` of a ring
        of ``rows`` on the device, with no copy to the host (``solver.check``). The next sort
        then takes every particle as inside the grid without asking: one that has left sorts
        last, past the cells' runs, where the passes skip it and park it beyond the grid
        (``_pass_body``) until a read of the ring (``finish_read``) tells the host and a sort
        drops it."""
        ring = pset.__dict__.get("_ring")
        if ring is None or ring.shape[0] != rows:  # a fifth column: the step's size (``size_step``)
            ring = pset.__dict__["_ring"] = cuda.device_array((rows, 5, 1), dtype=np.float64)
            pset.__dict__["_into_row"] = None
        grid = pset.__dict__.get("_grid")
        pset.__dict__["_stays"] = None
        final = self._final(pset, None, grid)
        if pset.__dict__.get("_into_row") != row:  # not reduced into the ring's row: copied there, on the device
            ring[row, :4].copy_to_device(final, stream=_stream())
        # the next check reduces into the next row (after a read, the first: ``start_read``)
        pset.__dict__["_into_row"] = row + 1 if row + 1 < rows else None
        if grid is not None:
            pset.__dict__["_stays"] = (pset["x"], pset.n, grid)

    def start_read(self, pset, rows):
        """The first ``rows`` rows of the ring ``check_later`` fills, copied to the host
        asynchronously on the run's stream into one of two pinned buffers (an event marks the
        copy's end); the launches queued after it go on while it runs, and the next check
        reduces into the ring's first row again (after the copy, in the stream's order).
        ``finish_read`` waits for it and returns the rows."""
        buffers = pset.__dict__.get("_reads")
        if buffers is None or buffers[0][0].shape[0] < rows:
            n = pset.__dict__["_ring"].shape[0]
            buffers = pset.__dict__["_reads"] = [(cuda.pinned_array((n, 5, 1), dtype=np.float64), cuda.event())
                                                 for _ in range(2)]
        k = pset.__dict__.get("_read_next", 0)
        pset.__dict__["_read_next"] = 1 - k
        host, copied = buffers[k]
        stream = _stream()
        pset.__dict__["_ring"][:rows].copy_to_host(host[:rows], stream=stream)
        copied.record(stream)
        pset.__dict__["_into_row"] = 0
        return k, rows

    def finish_read(self, pset, handle):
        """The rows ``start_read`` copied, once the copy is done (the host waits only for the
        launches queued before it): (max |v|^2, max |a|^2, non-finite count, count outside the
        grid, the step's size where the device made it) each. When any found a particle
        outside, the next sort reads its count back (and drops them)."""
        k, rows = handle
        host, copied = pset.__dict__["_reads"][k]
        copied.synchronize()
        out = [(vmax2, amax2, int(bad), int(outside), float(row[4])) for row in host[:rows, :, 0]
               for vmax2, amax2, bad, outside in (_row_values(row[:4], CHECK_OPS),)]
        if any(o[3] for o in out):
            pset.__dict__["_stays"] = None
        return out

    def size_step(self, pset, last, row, P, constants, stable, stepped, value):
        """The step's size made on the device from row ``last`` of the check's ring
        (``check_later``): dt = ``stable(vmax, amax, *constants)`` (``solver.timestep``),
        written into the device record the step's launches read ``P`` from (in P's precision),
        with each field (f, c, power) of ``stepped`` as ``value(c, power, dt)``, and into the
        fifth column of row ``row`` (in float64: the time the host sums). One thread: no copy,
        no wait. Made by the first thread of the sort's scan, the step's first launch, or in a
        launch of its own by any launch that reads P before it (``_params``)."""
        record = _params(P)
        _SIZING[0] = ((stable, tuple(stepped), value),
                      (record, pset.__dict__["_ring"], last, row, *(float(c) for c in constants)))
