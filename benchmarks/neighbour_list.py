"""Does a neighbour list with a skin pay on the CPU? The model's interaction pass (the step's
heaviest, run once per evaluation) over the cell walk, against the same pass over a list of
each fluid particle's neighbours within the support plus a skin, built once per step from
the same walk and reused by the step's evaluations (symplectic Verlet: two).

The list holds, for fluid particle i, the fluid and wall particles j of the cell walk within
(1 + skin) times the support, in the walk's order, so the list pass evaluates the same pairs
(the fluid's before the walls', where the walk alternates per row of cells: the results agree
to round-off, and the script stops when they do not). Printed: the pass over the walk, the list's build and the pass over the
list (medians of alternating rounds), the neighbours per particle, and the step's share:
two walk passes against one build and two list passes.

    python benchmarks/neighbour_list.py [CASE] [--n N] [--skin S] [--rounds R] [--backend cuda]

With ``--backend cuda`` the same on a GPU: the model's CUDA interaction kernel against a list
build kernel and a list pass kernel (one thread per particle; the list stored neighbour-major,
``list[m, i]``, so that a warp's loads of its m-th neighbours are one transaction), timed with
CUDA events. In Numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, a few hundred particles)
it checks the kernels against the walk; its times are not a GPU's.
"""
import argparse
import math
import statistics
import time
from collections import namedtuple

import numpy as np
from numba import config as numba_config
from numba import cuda, njit, prange
from numba.extending import register_jitable

from _measure import host, setup


#: particle i of the build: its position and cell (what the walk reads), and its lists
ListView = namedtuple("ListView", "x cell count1 list1 count2 list2")


def list_build_body(dim, zero, neighbour_major):
    """build(i, I, J1, J2, G, r2, L): the j of J1 and J2 within sqrt(r2) of particle i of
    I, in the cell walk's order (the backend's: per row of cells, J1's run, then J2's), into
    L's lists (a ``ListView``), at most the list's length; the counts go on past it, so that
    the caller sees the overflow. ``neighbour_major``: list[m, i] (a GPU's warp reads its
    m-th neighbours in one transaction), else list[i, m] (a CPU thread reads its own row).

    Its own walk, not a pass of the backend's (``make_pass`` with a pair that appends j):
    that build, tried, took 2.5 times as long on the CPU (a call per accepted pair), and with
    the pair inlined (``inline="always"``) Numba miscompiled the stores; nor is this body
    inlined, for the same reason (its lists came back wrong)."""

    @register_jitable
    def run_into(i, xi, yi, zi, J, j0, j1, r2, lst, n):
        for j in range(j0, j1):
            dx = xi - J.x[0, j]
            dy = yi - J.x[1, j]
            dz = zi - J.x[2, j] if dim == 3 else zero
            if dx * dx + dy * dy + dz * dz < r2:
                if neighbour_major:
                    if n < lst.shape[0]:
                        lst[n, i] = j
                elif n < lst.shape[1]:
                    lst[i, n] = j
                n += 1
        return n

    @register_jitable
    def build(i, I, J1, J2, G, r2, L):
        c = I.cell[i]
        xi = I.x[0, i]
        yi = I.x[1, i]
        zi = I.x[2, i] if dim == 3 else zero
        k = G.k
        kz = k if dim == 3 else 0
        n1 = 0
        n2 = 0
        for oz in range(-kz, kz + 1):
            for oy in range(-k, k + 1):
                cc = c + oy * G.sy + oz * G.sz
                n1 = run_into(i, xi, yi, zi, J1, J1.start[cc - k], J1.start[cc + k + 1], r2, L.list1, n1)
                n2 = run_into(i, xi, yi, zi, J2, J2.start[cc - k], J2.start[cc + k + 1], r2, L.list2, n2)
        L.count1[i] = n1
        L.count2[i] = n2

    return build


def list_body(dim, init, pair1, pair2, finish, zero, neighbour_major, inline):
    """body(i, I, J1, J2, P, L): the model's interaction of particle i over the lists of
    ``L`` (a ``ListView``), the pairs within the support in the lists' order (all fluid
    neighbours, then all wall ones)."""

    def make_visit(pair, first):
        @register_jitable(inline=inline)
        def visit(i, xi, yi, zi, I, J, L, P, acc):
            lst = L.list1 if first else L.list2
            n = L.count1[i] if first else L.count2[i]
            for m in range(n):
                j = lst[m, i] if neighbour_major else lst[i, m]
                dx = xi - J.x[0, j]
                dy = yi - J.x[1, j]
                dz = zi - J.x[2, j] if dim == 3 else zero
                r2 = dx * dx + dy * dy + dz * dz
                if r2 < P.rc2:
                    acc = pair(i, j, dx, dy, dz, math.sqrt(r2), I, J, P, acc)
            return acc

        return visit

    visit1, visit2 = make_visit(pair1, True), make_visit(pair2, False)

    @register_jitable(inline=inline)
    def body(i, I, J1, J2, P, L):
        xi = I.x[0, i]
        yi = I.x[1, i]
        zi = I.x[2, i] if dim == 3 else zero
        acc = init(i, I, P)
        acc = visit1(i, xi, yi, zi, I, J1, L, P, acc)
        acc = visit2(i, xi, yi, zi, I, J2, L, P, acc)
        finish(i, I, P, acc)

    return body


def cpu_loops(dim, terms, zero):
    """(build(I, J1, J2, G, r2, L), run(I, J1, J2, P, L)): the list's build and the
    interaction pass over it, as the CPU backend's loops (one thread per chunk of particles)."""
    build_one = list_build_body(dim, zero, False)
    body = list_body(dim, *terms, zero, False, "always")

    @njit(parallel=True, fastmath=True)
    def build(I, J1, J2, G, r2, L):
        for i in prange(I.x.shape[1]):
            build_one(i, I, J1, J2, G, r2, L)

    @njit(parallel=True, fastmath=True)
    def run(I, J1, J2, P, L):
        for i in prange(I.x.shape[1]):
            body(i, I, J1, J2, P, L)

    return build, run


def cuda_loops(dim, terms, zero, T):
    """The same as CUDA kernels, one thread per particle, the lists neighbour-major:
    build[...](I, J1, J2, G, r2, L) and run[...](I, J2, Pd, L) (J1 is I; ``Pd``: P's record
    on the device, read back into the model's namedtuple of type T as the backend's kernels
    do)."""
    from wcsph.backends.cuda import _loader

    build_one = list_build_body(dim, zero, True)
    body = list_body(dim, *terms, zero, True, "never")
    load = _loader(T)

    @cuda.jit
    def build(I, J1, J2, G, r2, L):
        i = cuda.grid(1)
        if i < I.x.shape[1]:
            build_one(i, I, J1, J2, G, r2, L)

    @cuda.jit
    def run(I, J2, Pd, L):
        i = cuda.grid(1)
        if i < I.x.shape[1]:
            body(i, I, I, J2, load(Pd), L)

    return build, run


def make_lists(n, build, neighbour_major, empty, top):
    """The lists of n particles (a ``ListView`` over the fluid view's x and cell, given by
    ``build(L)``), their length grown until every particle's neighbours fit.
    ``empty(shape)``: an uninitialised uint32 array of the backend; ``top(a)``: an array's
    largest value, on the host."""
    cap = 8
    while True:
        shape = (cap, n) if neighbour_major else (n, cap)
        L = build(empty(n), empty(shape), empty(n), empty(shape))
        most = max(top(L.count1), top(L.count2))
        if most <= cap:
            return L
        cap = int(most * 1.2) + 1


def compile_for_gpu(sim, cc=(9, 0)):
    """Compile the two CUDA kernels to PTX for capability ``cc`` with the argument types a GPU
    run passes them (taken from the CPU run ``sim``: the cell starts in the device's int64),
    as ``wcsph.validation.ptx`` does the backend's: the simulator runs their Python source and
    accepts what the CUDA compiler may refuse."""
    from numba import typeof

    from wcsph.backends.cuda import params_record
    from wcsph.validation.ptx import _use_capability, _with_device_starts

    _use_capability(cc)
    st = sim.state
    model = st.model
    f = _with_device_starts(model.view(st.fluid, model.fluid_view))
    w = _with_device_starts(model.view(st.walls, model.wall_view))
    dim, dtype, init, pair1, finish, pair2, _ = model._interaction_parts
    zero = np.dtype(dtype).type(0)
    build, run = cuda_loops(dim, (init, pair1, pair2 if pair2 is not None else pair1, finish), zero, type(st.P))
    n = st.fluid.n
    L = ListView(f.x, f.cell, *(np.zeros(s, np.uint32) for s in (n, (8, n), n, (8, n))))
    r2 = np.dtype(dtype).type(st.P.rc2)
    for name, kernel, args in (("build", build, (f, f, w, st.G, r2, L)), ("list pass", run, (f, w, params_record(st.P), L))):
        t0 = time.perf_counter()
        ptx, _ = cuda.compile_ptx(kernel.py_func, tuple(typeof(x) for x in args), cc=cc)
        print(f"{name}: {len(ptx)} characters of PTX for sm_{cc[0]}{cc[1]} in {time.perf_counter() - t0:.1f} s")


def clock(cuda_on):
    """(mark, seconds): a point of the run's timeline and the seconds between two: CUDA
    events on the backend's stream on a GPU, the wall clock after each launch elsewhere (the
    CPU, Numba's CUDA simulator)."""
    if cuda_on and not numba_config.ENABLE_CUDASIM:
        from wcsph.backends.cuda import _stream

        def mark():
            e = cuda.event()
            e.record(_stream())
            return e

        def seconds(e0, e1):
            e1.synchronize()
            return e0.elapsed_time(e1) / 1e3

        return mark, seconds

    def mark():
        if cuda_on:
            cuda.synchronize()
        return time.perf_counter()

    return mark, lambda t0, t1: t1 - t0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("case", nargs="?", default="dam_break_3d_bi")
    ap.add_argument("--n", type=int, default=46_000)
    ap.add_argument("--skin", type=float, default=0.1, help="the skin as a fraction of the support")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--backend", default="cpu", choices=("cpu", "cuda"))
    ap.add_argument("--precision", default="float32", choices=("float32", "float64"))
    ap.add_argument("--ptx", action="store_true", help="compile the CUDA kernels for sm_90 (no GPU needed) and stop")
    a = ap.parse_args()
    print(host())
    sim = setup(a.case, a.n, precision=a.precision, backend="cpu" if a.ptx else a.backend)
    if a.ptx:
        compile_for_gpu(sim)
        return
    st = sim.state
    model, P, G, be = st.model, st.P, st.G, st.backend
    on_gpu = a.backend == "cuda"
    f = model.view(st.fluid, model.fluid_view)
    w = model.view(st.walls, model.wall_view)
    dim, dtype, init, pair1, finish, pair2, _ = model._interaction_parts
    terms = (init, pair1, pair2 if pair2 is not None else pair1, finish)
    zero = np.dtype(dtype).type(0)
    r2 = dtype(float(P.rc2) * (1 + a.skin) ** 2)  # the list's radius: the support and the skin
    if on_gpu:
        from wcsph.backends.cuda import THREADS, _blocks, _params, _stream

        build_k, run_k = cuda_loops(dim, terms, zero, type(P))
        launch = (_blocks(st.fluid.n), THREADS, _stream())

        def empty(shape):
            return cuda.device_array(shape, np.uint32, stream=_stream())

        def build(L):
            build_k[launch](f, f, w, G, r2, L)

        def list_pass(L):
            run_k[launch](f, w, _params(P), L)
    else:
        build_c, run_c = cpu_loops(dim, terms, zero)

        def empty(shape):
            return np.empty(shape, np.uint32)

        def build(L):
            build_c(f, f, w, G, r2, L)

        def list_pass(L):
            run_c(f, f, w, P, L)

    def build_new(c1, l1, c2, l2):
        L = ListView(f.x, f.cell, c1, l1, c2, l2)
        build(L)
        return L

    L = make_lists(st.fluid.n, build_new, on_gpu, empty, lambda c: int(be.to_host(c).max()))
    fields = ["dvdt"] + (["drhodt"] if "drhodt" in st.fluid.arrays else [])
    model.interaction(f, f, w, P, G)
    ref = [np.array(a, copy=True) for a in st.host(st.fluid, *fields)]  # on the CPU, the arrays themselves
    list_pass(L)
    got = st.host(st.fluid, *fields)
    diff = max(float(np.max(np.abs(g - r)) / max(np.max(np.abs(r)), 1e-30)) for g, r in zip(got, ref))
    c1, c2 = be.to_host(L.count1), be.to_host(L.count2)
    print(f"{a.case} ({a.backend}): {st.fluid.n} fluid, {st.walls.n} wall particles, skin {a.skin} of the "
          f"support; list: {c1.mean():.1f} fluid + {c2.mean():.1f} wall neighbours a particle (length "
          f"{L.list1.shape[0 if on_gpu else 1]}); list pass vs walk: largest difference {diff:.2e} "
          f"({', '.join(fields)}), relative")
    agree(diff, dtype)
    mark, seconds = clock(on_gpu)
    walk_t, build_t, list_t = [], [], []
    for _ in range(a.rounds):
        t0 = mark()
        model.interaction(f, f, w, P, G)
        t1 = mark()
        build(L)
        t2 = mark()
        list_pass(L)
        t3 = mark()
        walk_t.append(seconds(t0, t1))
        build_t.append(seconds(t1, t2))
        list_t.append(seconds(t2, t3))
    report(walk_t, build_t, list_t)


def agree(diff, dtype):
    """Stop when the list pass's results are not the walk's to round-off (the same pairs,
    summed in another order: fluid before walls)."""
    tol = 1e-5 if np.dtype(dtype) == np.float32 else 1e-12
    if not diff <= tol:
        raise SystemExit(f"the list pass differs from the walk by {diff:.2e} (more than {tol:g})")


def report(walk_t, build_t, list_t):
    wk, bd, ls = (statistics.median(v) * 1e3 for v in (walk_t, build_t, list_t))
    print(f"walk pass {wk:.2f} ms, list build {bd:.2f} ms, list pass {ls:.2f} ms; "
          f"a step's two evaluations: walk {2 * wk:.2f} ms, list {bd + 2 * ls:.2f} ms "
          f"({(bd + 2 * ls) / (2 * wk):.2f} of the walk)")


if __name__ == "__main__":
    main()
