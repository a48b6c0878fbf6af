"""CPU backend: Numba ``parallel=True`` loops over a cell list of particles physically
reordered by cell (counting sort every step), so neighbours are read sequentially. A process
that runs one thread (``NUMBA_NUM_THREADS=1``, an MPI rank per core, a test worker) compiles
the loops of its passes without ``parallel`` (``_loop``)."""
from contextlib import contextmanager

import numpy as np
import numba
from numba import literal_unroll, njit, prange
from numba.extending import overload, register_jitable

from .numba_cache import VARIANT, compiled_once, saved_first
from .walk import body_term, every, make_particle_check, make_periodic_walk, make_run_visitor


#: below this many particles the sort, the per-particle maps and the checks run on one
#: thread: each is a few microseconds of work there, less than waking the other threads
#: (the sort of 2,450 particles took 71 us as parallel loops, 45 us on one thread and 21 us
#: as one fused call)
SERIAL_BELOW = 20_000

#: particles per chunk of the dynamically scheduled pass loops (measured: 32-128 equally good)
CHUNK = 128


def _loop(**options):
    """``njit(parallel=True, **options)`` for a loop made at setup (a pass, a map, a
    reduction), or a plain loop where the process runs one thread
    (``numba.get_num_threads()`` when the loop is made). Numba's parallel form compiles the
    body twice (a gufunc of its own, then the loop that calls it): a cold compile takes about
    a third less without it (measured: the first steps of ``hydrostatic_2d_bi``, 26.2 s
    against 16.4). The plain loop takes NumPy's error model, as the parallel body does:
    with Python's, each division carries a test for zero and the pair terms were not inlined
    (measured, the WCSPH-BI interaction pass on one thread: 400 times the parallel loop's
    time, the views' arrays reference-counted at each call; 2 times with Numba's reference
    counting off; the same time with NumPy's error model). The plain
    loop is a variant of its own in Numba's cache and in the JIT's names
    (``numba_cache.VARIANT``): a process of either kind never loads or links the other's."""
    parallel = numba.get_num_threads() > 1

    def decorate(fn):
        if parallel:
            return njit(parallel=True, **options)(fn)
        setattr(fn, VARIANT, "serial")
        return njit(error_model="numpy", **options)(fn)

    return decorate


@register_jitable(inline="always")
def _cell_id(x, i, origin, inv_cell, nx, ny, nz, ncells, k):
    """The cell of particle i, or ``ncells`` outside the domain (the ghost layers). Inlined
    by Numba: left as a call, it made the cell-id loop 4-6 times slower."""
    cx = np.int64(np.floor((x[0, i] - origin[0]) * inv_cell[0]))
    cy = np.int64(np.floor((x[1, i] - origin[1]) * inv_cell[1]))
    inside = (cx >= k) & (cx < nx - k) & (cy >= k) & (cy < ny - k)
    cz = np.int64(0)
    if x.shape[0] == 3:
        cz = np.int64(np.floor((x[2, i] - origin[2]) * inv_cell[2]))
        inside = inside & (cz >= k) & (cz < nz - k)
    return cx + nx * (cy + ny * cz) if inside else ncells


@saved_first
@njit(parallel=True, fastmath=True, cache=True)
def _cell_ids(x, origin, inv_cell, nx, ny, nz, ncells, k, cell):
    for i in prange(x.shape[1]):
        cell[i] = _cell_id(x, i, origin, inv_cell, nx, ny, nz, ncells, k)


@compiled_once
@njit(cache=True)
def _counting_sort(cell, ncells, start, perm):
    """Stable counting sort by cell; ``start`` gets ncells + 2 entries (the extra cell id
    ``ncells`` holds particles outside the domain). ``start`` is unsigned so that the loop's
    neighbour index is too: Numba then drops its negative-index wrap-around code, which made
    the neighbour loop three times faster."""
    one = np.uint64(1)
    start[:] = 0
    for i in range(cell.size):
        start[cell[i] + 1] += one
    for c in range(ncells + 1):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    for i in range(cell.size):
        c = cell[i]
        perm[fill[c]] = i
        fill[c] += one


@compiled_once
@njit(cache=True)
def _body_sums(x, load, body, rows, refs, out):
    """out[r] = (force, torque about refs[r]) summed over the wall points i with
    rows[body[i]] = r, in the points' order (``CpuBackend.body_sums``)."""
    out[:] = 0.0
    for i in range(x.shape[1]):
        b = body[i]
        if b < 0 or b >= rows.size or rows[b] < 0:
            continue
        r = rows[b]
        for comp in range(6):
            out[r, comp] += body_term(x, load, refs, i, r, comp)


def _copy(src, perm, dst):
    """dst[..., k] = src[..., perm[k]] for a scalar (N,) or vector (dim, N) field."""


@overload(_copy)
def _copy_impl(src, perm, dst):
    if src.ndim == 1:
        def copy1(src, perm, dst):
            for k in range(perm.size):
                dst[k] = src[perm[k]]
        return copy1

    def copy2(src, perm, dst):
        for d in range(src.shape[0]):
            for k in range(perm.size):
                dst[d, k] = src[d, perm[k]]
    return copy2


@compiled_once
@njit(fastmath=True, cache=True)
def _sort_small(x, origin, inv_cell, nx, ny, nz, ncells, k, cell, start, perm, pairs):
    """The whole sort in one call on one thread: cell ids, counting sort and the gather of
    every (source, destination) pair of ``pairs``. Below ``SERIAL_BELOW`` particles this is
    one compiled call per step instead of one parallel region per field."""
    for i in range(x.shape[1]):
        cell[i] = _cell_id(x, i, origin, inv_cell, nx, ny, nz, ncells, k)
    _counting_sort(cell, ncells, start, perm)
    for pair in literal_unroll(pairs):
        _copy(pair[0], perm, pair[1])


@compiled_once
@njit(parallel=True, cache=True)
def _gather1(src, perm, dst):
    for k in prange(dst.shape[0]):
        dst[k] = src[perm[k]]


@compiled_once
@njit(parallel=True, cache=True)
def _gather2(src, perm, dst):
    for k in prange(dst.shape[1]):
        for d in range(src.shape[0]):
            dst[d, k] = src[d, perm[k]]


@compiled_once
@njit(parallel=True, cache=True)
def _drop_cells(cell, drop, ncells):
    for i in prange(cell.size):
        if drop[i]:
            cell[i] = ncells


#: the check of one particle, inlined into the CPU's loop (``walk.make_particle_check``)
_particle_check = make_particle_check(inline="always")


@compiled_once
@njit(parallel=True, cache=True)
def _check(x, v, a, owned):
    """Largest |v|^2 and |a|^2, and the count of particles with a non-finite x, v or a,
    over the particles with ``owned[i]`` (every particle when ``owned`` is empty: a process
    of a decomposed run skips its ghost copies). Not fastmath: it must see NaN and inf."""
    vmax2 = 0.0
    amax2 = 0.0
    bad = 0
    all_owned = owned.size == 0
    for i in prange(x.shape[1]):  # without a branch: the loop vectorises
        mine = all_owned or owned[i] != 0
        s, q, ok = _particle_check(x, v, a, i)
        vmax2 = max(vmax2, s if ok and mine else 0.0)
        amax2 = max(amax2, q if ok and mine else 0.0)
        bad += 0 if ok or not mine else 1
    return vmax2, amax2, bad


def _make_pass_loop(dim, init, pair1, pair2, finish, use2, zero, cache=True, branchless=False, periodic=None,
                    keep=None):
    """The one CPU neighbour loop: for each particle i of set I, visit the particles of
    J1 (and J2 when ``use2``) within the support radius, fold them into an accumulator with
    ``pair*``, then store it with ``finish``. Per cell row the 2k + 1 x-adjacent cells
    (k = ``G.k`` cells per support) are one contiguous run of sorted particles.

    Particles are handed to the threads in chunks of ``CHUNK`` as they free up, not in one
    equal share each: the cost per particle varies (free surface, walls), and the static
    split left one thread idle for a third of a 2,500-particle pass (538 -> 370 us). The
    chunk size is a per-thread setting of Numba's scheduler that compiled code cannot set
    and still be cached, hence the Python wrapper.

    ``periodic`` (a flag per axis, or None): the loop of a grid with periodic axes, which
    walks the cells around i through ``walk.make_periodic_walk``. ``keep`` (keep(i, I, P), or
    None for every i): the particles of I the pass visits; the others keep what they hold."""
    sift = keep is not None  # a constant of the compiled loop: without keep, no test at all
    keep = every if keep is None else keep
    visit1 = make_run_visitor(dim, pair1, zero, inline="always", branchless=branchless)
    visit2 = make_run_visitor(dim, pair2, zero, inline="always", branchless=branchless)
    if periodic is not None and any(periodic):
        walk = make_periodic_walk(dim, visit1, visit2, use2, zero, periodic, inline="always")

        @saved_first
        @_loop(fastmath=True, cache=cache)
        def run_periodic(I, J1, J2, P, G):
            for i in prange(I.x.shape[1]):
                if sift and not keep(i, I, P):
                    continue
                zi = I.x[2, i] if dim == 3 else zero
                acc = walk(i, I.x[0, i], I.x[1, i], zi, I.cell[i], I, J1, J2, P, G, init(i, I, P))
                finish(i, I, P, acc)

        return _chunked(run_periodic)

    @saved_first
    @_loop(fastmath=True, cache=cache)
    def run(I, J1, J2, P, G):
        k = G.k
        kz = k if dim == 3 else 0
        for i in prange(I.x.shape[1]):
            if sift and not keep(i, I, P):
                continue
            c = I.cell[i]
            xi = I.x[0, i]
            yi = I.x[1, i]
            zi = I.x[2, i] if dim == 3 else zero
            acc = init(i, I, P)
            for oz in range(-kz, kz + 1):
                for oy in range(-k, k + 1):
                    cc = c + oy * G.sy + oz * G.sz
                    acc = visit1(i, xi, yi, zi, I, J1, J1.start[cc - k], J1.start[cc + k + 1], P, acc)
                    if use2:
                        acc = visit2(i, xi, yi, zi, I, J2, J2.start[cc - k], J2.start[cc + k + 1], P, acc)
            finish(i, I, P, acc)

    return _chunked(run)


def _chunked(run):
    def chunked(I, J1, J2, P, G):
        previous = numba.set_parallel_chunksize(CHUNK)
        try:
            run(I, J1, J2, P, G)
        finally:
            numba.set_parallel_chunksize(previous)

    return chunked


@compiled_once
@njit(parallel=True, cache=True)
def _wrap(x, lo, length, inv_cell, origin, k, real, axes):
    """Put particles that left a periodic box through one side back at the other; a position
    that rounding would still put in the ghost cells goes to the lower face."""
    for i in prange(x.shape[1]):
        for a in axes:
            xa = x[a, i]
            if xa < lo[a] or xa >= lo[a] + length[a]:
                xa = lo[a] + (xa - lo[a]) % length[a]
                c = np.int64(np.floor((xa - origin[a]) * inv_cell[a]))
                if c < k or c >= k + real[a]:
                    xa = lo[a]
                x[a, i] = xa


@contextmanager
def _threads_for(n):
    """One thread for work on fewer than ``SERIAL_BELOW`` particles, all threads otherwise."""
    if n >= SERIAL_BELOW:
        yield
        return
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(previous)


def _make_map_loop(fn):
    @saved_first
    @_loop(fastmath=True, cache=True)
    def run(I, P):
        for i in prange(I.x.shape[1]):
            fn(i, I, P)

    def call(I, P):
        with _threads_for(I.x.shape[1]):
            run(I, P)

    return call


def _make_fused_map_loop(fn, then):
    @saved_first
    @_loop(fastmath=True, cache=True)
    def run(I, P, J):
        for i in prange(I.x.shape[1]):
            fn(i, I, P)
            then(i, J, P, I.rho[i])

    def call(I, P, J):
        with _threads_for(I.x.shape[1]):
            run(I, P, J)

    return call


def _then_after(run_pass, then):
    @saved_first
    @_loop(fastmath=True, cache=True)
    def run(I, S, R, P):
        for i in prange(I.x.shape[1]):
            then(i, I, S, R, P)

    def call(I, J1, J2, P, G, S, R):
        run_pass(I, J1, J2, P, G)
        with _threads_for(I.x.shape[1]):
            run(I, S, R, P)

    return call


#: ``owned`` of a process that holds every particle it reduces over (no ghost copies)
EVERY = np.zeros(0, dtype=np.uint8)


def _make_reduce_loop(fn):
    @saved_first
    @_loop(fastmath=True, cache=True)
    def run(I, P, owned):
        s1 = 0.0
        s2 = 0.0
        mx = 0.0
        every = owned.size == 0
        for i in prange(I.x.shape[1]):
            if every or owned[i] != 0:
                a, b, c = fn(i, I, P)
                s1 += a
                s2 += b
                mx = max(mx, c)
        return s1, s2, mx

    def call(I, P, owned=None):
        with _threads_for(I.x.shape[1]):
            return run(I, P, EVERY if owned is None else owned)

    return call


class CpuBackend:
    name = "cpu"
    #: the most particles in a set, and cells in a grid, that the sort's indices address
    max_index = int(np.iinfo(np.int64).max)

    def to_device(self, a):
        return np.ascontiguousarray(a)

    def to_host(self, a):
        return np.asarray(a)

    def make_pass(self, dim, dtype, init, pair1, finish, pair2=None, cache=True, branchless=False,
                  periodic=None, then=None, parts=None, keep=None):
        """The compiled loop of one pass. ``cache=False`` for passes whose set or parameter
        types live outside the package (Numba's cache index of the loop is shared by all its
        closures and must unpickle in every process). ``branchless``: a performance choice
        of the pass (see ``walk.make_run_visitor``); the result is the same. ``periodic``:
        the grid's periodic axes (a flag per axis). ``keep``: keep(i, I, P), the particles of
        I the pass visits (default every one); the others keep what they hold.

        ``then``: then(i, I, S, R, P) for each particle after its ``finish``, called as
        pass(I, J1, J2, P, G, S, R); it may write only what no particle of the pass reads.
        Here a loop of its own after the pass (``parts``: the pass without it, already
        made): a GPU saves a launch by fusing them, a CPU little, and a compiler that sees
        ``finish``'s stores and ``then``'s loads in one fastmath loop may reassociate
        across them."""
        if then is not None:
            return _then_after(parts, then)
        use2 = pair2 is not None
        return _make_pass_loop(dim, init, pair1, pair2 if use2 else pair1, finish, use2,
                               np.dtype(dtype).type(0), cache, branchless, periodic, keep)

    def wrap(self, pset, grid):
        """Particles of ``pset`` that crossed a periodic side re-enter at the other."""
        if not grid.any_periodic or not pset.n:
            return
        x = pset["x"]
        dt = x.dtype.type
        lo, length = grid.lengths()
        origin, inv = grid.geometry(dt)
        axes = np.array([a for a in range(grid.dim) if grid.periodic[a]], dtype=np.int64)
        real = np.asarray(grid.shape[: grid.dim], dtype=np.int64) - 2 * grid.reach
        with _threads_for(pset.n):
            _wrap(x, lo.astype(dt), length.astype(dt), inv, origin, grid.reach, real, axes)

    def make_map(self, fn, then=None):
        """A per-particle map fn(i, I, P), called as map(I, P). With ``then``, one loop also
        runs then(i, J, P, rho) for each particle after fn, J another view of the same
        particles and rho the density fn left in I (read through I: a compiler that takes
        two views for two arrays may not reorder it before fn's write), called as
        map(I, P, J)."""
        return _make_map_loop(fn) if then is None else _make_fused_map_loop(fn, then)

    #: a tail (``make_tail``) leaves the check to ``check`` (a reduction of its own)
    fuses_check = False
    #: the check's figures are on the host at once: no ring to read every few steps
    defers_check = False

    def make_tail(self, dim, dtype, fn, walk=None, parts=None):
        """The step's last map fn(i, I, P) followed, when ``walk`` = (init, pair, finish) is
        given, by the pass of each particle i of the view F over the set J (each particle's
        own state and its J neighbours: nothing another particle writes), called as
        tail(I, P, F, J, G, measure=None); ``measure`` is for a backend that checks there
        (``fuses_check``). ``parts``: the map and the pass, already made by ``make_map`` and
        ``make_pass``. Here they run one after the other: a GPU saves a launch by fusing
        them, a CPU little, and one fastmath loop would let the compiler hand the walk a
        position that is not the one stored (measured: not bit for bit in float32)."""
        run_map, run_pass = parts

        def tail(I, P, F=None, J=None, G=None, measure=None):
            run_map(I, P)
            if walk is not None:
                run_pass(F, J, J, P, G)

        return tail

    def make_reduce(self, fn):
        """A per-particle function returning (a, b, c) reduced to (sum a, sum b, max c), over
        the particles with ``owned[i]`` when the call passes ``owned`` (a decomposed run)."""
        return _make_reduce_loop(fn)

    def sort(self, pset, grid, drop=None, refresh=None, inside=False):
        """Reorder ``pset`` by cell; drop particles outside the domain. Returns how many
        were dropped (``inside``: the caller knows that none is; the count is made here
        anyway, at no cost to speak of). Each field is gathered into a spare array kept from the previous sort
        (``_spare_NAME``), which then becomes the next spare: no allocation per step.
        ``drop``: flags (uint8) of particles to drop as well (a decomposed run's old ghosts
        and emigrants). ``refresh`` = (fn, map, view, P): after the sort, ``map`` (made of
        fn(i, J, P, rho) by ``make_map``) over ``view(pset)`` with P (a GPU runs fn in the
        launch that moves the fields)."""
        dropped = self._sort(pset, grid, drop)
        if refresh is not None:
            _, run, view, P = refresh
            run(view(pset), P)
        return dropped

    def _sort(self, pset, grid, drop):
        g = grid.view()
        x = pset["x"]
        origin, inv_cell = grid.geometry(x.dtype.type)
        n = pset.n
        if "cell" not in pset.arrays:
            pset["cell"] = np.empty(n, dtype=np.int64)  # gathered too: the loops read it by i
        if "start" not in pset.arrays:
            pset["start"] = np.empty(g.ncells + 2, dtype=np.uint64)
        cell, start = pset["cell"], pset["start"]
        perm = self._spare(pset, "_perm", cell.shape, cell.dtype)
        names = pset.sorted_fields()
        if drop is None and n < SERIAL_BELOW:  # one fused call; a particle rarely leaves
            outs = [self._spare(pset, "_spare_" + k, pset[k].shape, pset[k].dtype) for k in names]
            _sort_small(x, origin, inv_cell, g.nx, g.ny, g.nz, g.ncells, g.k, cell, start, perm,
                        tuple((pset[k], out) for k, out in zip(names, outs)))
            self._swap(pset, names, outs)
            n_in = int(start[g.ncells])
            if n_in < n:
                for k in pset.per_particle():
                    pset[k] = np.ascontiguousarray(pset[k][..., :n_in])
                pset.n = n_in
            return n - n_in
        with _threads_for(n):
            _cell_ids(x, origin, inv_cell, g.nx, g.ny, g.nz, g.ncells, g.k, cell)
            if drop is not None:
                _drop_cells(cell, drop, g.ncells)
        _counting_sort(cell, g.ncells, start, perm)
        n_in = int(start[g.ncells])  # the dropped ones sort last: gather the first n_in
        scratch = [k for k in pset.per_particle() if k not in names]
        outs = [self._spare(pset, "_spare_" + k, pset[k].shape[:-1] + (n_in,), pset[k].dtype) for k in names]
        with _threads_for(n_in):
            for k, out in zip(names, outs):
                (_gather1 if out.ndim == 1 else _gather2)(pset[k], perm, out)
        self._swap(pset, names, outs)
        if n_in < n:
            for k in scratch:  # written before they are read: only their size matters
                pset[k] = np.empty(pset[k].shape[:-1] + (n_in,), dtype=pset[k].dtype)
            pset.n = n_in
        return n - n_in

    @staticmethod
    def _swap(pset, names, outs):
        for k, out in zip(names, outs):
            pset["_spare_" + k] = pset[k]
            pset[k] = out

    @staticmethod
    def _spare(pset, key, shape, dtype):
        a = pset.arrays.get(key)
        if a is None or a.shape != shape or a.dtype != dtype:
            a = np.empty(shape, dtype=dtype)
            pset[key] = a
        return a

    def take(self, a, idx):
        """a[..., idx], a new host array (a halo's send buffer)."""
        return a[..., idx]

    def put(self, a, idx, values):
        """a[..., idx] = values, in place."""
        a[..., idx] = values

    def index(self, idx):
        """An index list as ``take`` and ``put`` take it."""
        return np.ascontiguousarray(idx, dtype=np.int64)

    def stage(self, name, a):
        """A small host array for the loops after it (a GPU's ``stage`` copies it there)."""
        return np.ascontiguousarray(a)

    def body_sums(self, x, load, body, rows, refs):
        """The fluid's load on each body as one (bodies, 6) float64 host array: row r holds
        the force (x, y, z) and the torque about refs[r] (x, y, z; in 2D z alone) summed over
        the wall points i whose body b = body[i] has rows[b] = r (-1: none). ``x``, ``load``:
        the walls' positions and loads (dim, n); ``rows``, ``refs``: host arrays (refs
        (bodies, 3))."""
        out = np.empty((len(refs), 6))
        _body_sums(x, load, body, np.ascontiguousarray(rows, dtype=np.int64), np.ascontiguousarray(refs, dtype=float), out)
        return out

    def check(self, pset, owned=None):
        """(max |v|^2, max |a|^2, non-finite count) over ``pset``, or its particles with
        ``owned[i]``."""
        with _threads_for(pset.n):
            vmax2, amax2, bad = _check(pset["x"], pset["v"], pset["dvdt"], EVERY if owned is None else owned)
        return float(vmax2), float(amax2), int(bad)
