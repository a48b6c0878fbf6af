"""Does a neighbour list with a skin pay on the CPU? The model's interaction pass (the step's
heaviest, run once per evaluation) over the cell walk, against the same pass over a list of
each fluid particle's neighbours within the support plus a skin, built once per step from
the same walk and reused by the step's evaluations (symplectic Verlet: two).

The list holds, for fluid particle i, the fluid and wall particles j of the cell walk within
(1 + skin) times the support, in the walk's order, so the list pass evaluates the same pairs
in the same order. Printed: the pass over the walk, the list's build and the pass over the
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

import numpy as np
from numba import cuda, njit, prange
from numba.extending import register_jitable

from _measure import host, setup


def make_list_builder(dim, zero):
    """build(I, J1, J2, G, r2, cap, count1, list1, count2, list2): for each i of I the j of
    J1 (and J2) within sqrt(r2), in the cell walk's order, in list*[i, :count*[i]] (at most
    ``cap`` each; the count goes on past it, so that the caller sees the overflow)."""

    @register_jitable(inline="always")
    def run_into(i, xi, yi, zi, J, j0, j1, r2, lst, n):
        for j in range(j0, j1):
            dx = xi - J.x[0, j]
            dy = yi - J.x[1, j]
            dz = zi - J.x[2, j] if dim == 3 else zero
            if dx * dx + dy * dy + dz * dz < r2:
                if n < lst.shape[1]:
                    lst[i, n] = np.uint32(j)
                n += 1
        return n

    @njit(parallel=True, fastmath=True)
    def build(I, J1, J2, G, r2, count1, list1, count2, list2):
        k = G.k
        kz = k if dim == 3 else 0
        for i in prange(I.x.shape[1]):
            c = I.cell[i]
            xi = I.x[0, i]
            yi = I.x[1, i]
            zi = I.x[2, i] if dim == 3 else zero
            n1 = 0
            n2 = 0
            for oz in range(-kz, kz + 1):
                for oy in range(-k, k + 1):
                    cc = c + oy * G.sy + oz * G.sz
                    n1 = run_into(i, xi, yi, zi, J1, J1.start[cc - k], J1.start[cc + k + 1], r2, list1, n1)
                    n2 = run_into(i, xi, yi, zi, J2, J2.start[cc - k], J2.start[cc + k + 1], r2, list2, n2)
            count1[i] = n1
            count2[i] = n2

    return build


def make_list_pass(dim, init, pair1, pair2, finish, zero):
    """The interaction pass over the lists: the pairs within the support, in the list's order."""

    def make_visit(pair):
        @register_jitable(inline="always")
        def visit(i, xi, yi, zi, I, J, lst, n, P, acc):
            for m in range(n):
                j = lst[i, m]
                dx = xi - J.x[0, j]
                dy = yi - J.x[1, j]
                dz = zi - J.x[2, j] if dim == 3 else zero
                r2 = dx * dx + dy * dy + dz * dz
                if r2 < P.rc2:
                    acc = pair(i, j, dx, dy, dz, np.sqrt(r2), I, J, P, acc)
            return acc
        return visit

    visit1 = make_visit(pair1)
    visit2 = make_visit(pair2)

    @njit(parallel=True, fastmath=True)
    def run(I, J1, J2, P, count1, list1, count2, list2):
        for i in prange(I.x.shape[1]):
            xi = I.x[0, i]
            yi = I.x[1, i]
            zi = I.x[2, i] if dim == 3 else zero
            acc = init(i, I, P)
            acc = visit1(i, xi, yi, zi, I, J1, list1, count1[i], P, acc)
            acc = visit2(i, xi, yi, zi, I, J2, list2, count2[i], P, acc)
            finish(i, I, P, acc)

    return run


def make_cuda_kernels(dim, init, pair1, pair2, finish, zero):
    """build(I, J1, J2, G, r2, count1, list1, count2, list2) and the list pass
    run(I, J1, J2, Pd, count1, list1, count2, list2) as CUDA kernels (``load``: P's record
    read back into the model's namedtuple, as the backend's kernels do)."""
    from wcsph.backends.cuda import _loader

    @cuda.jit(device=True)
    def run_into(i, xi, yi, zi, J, j0, j1, r2, lst, n):
        for j in range(j0, j1):
            dx = xi - J.x[0, j]
            dy = yi - J.x[1, j]
            dz = zi - J.x[2, j] if dim == 3 else zero
            if dx * dx + dy * dy + dz * dz < r2:
                if n < lst.shape[0]:
                    lst[n, i] = j
                n += 1
        return n

    @cuda.jit
    def build(I, J1, J2, G, r2, count1, list1, count2, list2):
        i = cuda.grid(1)
        if i >= I.x.shape[1]:
            return
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
                n1 = run_into(i, xi, yi, zi, J1, J1.start[cc - k], J1.start[cc + k + 1], r2, list1, n1)
                n2 = run_into(i, xi, yi, zi, J2, J2.start[cc - k], J2.start[cc + k + 1], r2, list2, n2)
        count1[i] = n1
        count2[i] = n2

    def make_visit(pair):
        @cuda.jit(device=True)
        def visit(i, xi, yi, zi, I, J, lst, n, P, acc):
            for m in range(n):
                j = lst[m, i]
                dx = xi - J.x[0, j]
                dy = yi - J.x[1, j]
                dz = zi - J.x[2, j] if dim == 3 else zero
                r2 = dx * dx + dy * dy + dz * dz
                if r2 < P.rc2:
                    acc = pair(i, j, dx, dy, dz, math.sqrt(r2), I, J, P, acc)
            return acc
        return visit

    visit1, visit2 = make_visit(pair1), make_visit(pair2)
    made = {}

    def run_for(T):
        if T not in made:
            load = _loader(T)

            @cuda.jit
            def run(I, J2, Pd, count1, list1, count2, list2):
                i = cuda.grid(1)
                if i >= I.x.shape[1]:
                    return
                P = load(Pd)
                xi = I.x[0, i]
                yi = I.x[1, i]
                zi = I.x[2, i] if dim == 3 else zero
                acc = init(i, I, P)
                acc = visit1(i, xi, yi, zi, I, I, list1, count1[i], P, acc)
                acc = visit2(i, xi, yi, zi, I, J2, list2, count2[i], P, acc)
                finish(i, I, P, acc)

            made[T] = run
        return made[T]

    return build, run_for


def main_cuda(a, sim):
    from wcsph.backends.cuda import THREADS, _blocks, _params, _stream

    st = sim.state
    model, P, G = st.model, st.P, st.G
    f = model.view(st.fluid, model.fluid_view)
    w = model.view(st.walls, model.wall_view)
    dim, dtype, init, pair1, finish, pair2, _ = model._interaction_parts
    zero = np.dtype(dtype).type(0)
    n = st.fluid.n
    r2 = dtype(float(P.rc2) * (1 + a.skin) ** 2)
    build, run_for = make_cuda_kernels(dim, init, pair1, pair2 if pair2 is not None else pair1, finish, zero)
    s = _stream()
    grid = (_blocks(n), THREADS, s)
    c1 = cuda.device_array(n, np.uint32)
    c2 = cuda.device_array(n, np.uint32)
    cap = 8
    while True:
        l1 = cuda.device_array((cap, n), np.uint32)
        l2 = cuda.device_array((cap, n), np.uint32)
        build[grid](f, f, w, G, r2, c1, l1, c2, l2)
        top = max(int(c1.copy_to_host(stream=s).max()), int(c2.copy_to_host(stream=s).max()))
        s.synchronize()
        if top <= cap:
            break
        cap = int(top * 1.2) + 1
    run = run_for(type(P))
    Pd = _params(P)
    dvdt = st.fluid["dvdt"]
    model.interaction(f, f, w, P, G)
    ref = dvdt.copy_to_host(stream=s)
    run[grid](f, w, Pd, c1, l1, c2, l2)
    got = dvdt.copy_to_host(stream=s)
    s.synchronize()
    dv = float(np.max(np.abs(got - ref)) / np.max(np.abs(ref)))
    h1, h2 = c1.copy_to_host(), c2.copy_to_host()
    print(f"{a.case} (cuda): {n} fluid, {st.walls.n} wall particles, skin {a.skin} of the support; "
          f"list: {h1.mean():.1f} fluid + {h2.mean():.1f} wall neighbours a particle (cap {cap}); "
          f"list pass vs walk: largest difference {dv:.2e} (dv/dt), relative")
    agree(dv, dtype)
    from numba import config

    def mark():  # a point of the stream's timeline: a CUDA event; wall clock in the simulator
        if config.ENABLE_CUDASIM:
            s.synchronize()
            return time.perf_counter()
        e = cuda.event()
        e.record(s)
        return e

    def seconds(e0, e1):
        if config.ENABLE_CUDASIM:
            return e1 - e0
        e1.synchronize()
        return e0.elapsed_time(e1) / 1e3

    walk_t, build_t, list_t = [], [], []
    for _ in range(a.rounds):
        cuda.synchronize()
        e0 = mark()
        model.interaction(f, f, w, P, G)
        e1 = mark()
        build[grid](f, f, w, G, r2, c1, l1, c2, l2)
        e2 = mark()
        run[grid](f, w, Pd, c1, l1, c2, l2)
        e3 = mark()
        walk_t.append(seconds(e0, e1))
        build_t.append(seconds(e1, e2))
        list_t.append(seconds(e2, e3))
    return walk_t, build_t, list_t


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("case", nargs="?", default="dam_break_3d_bi")
    ap.add_argument("--n", type=int, default=46_000)
    ap.add_argument("--skin", type=float, default=0.1, help="the skin as a fraction of the support")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--backend", default="cpu", choices=("cpu", "cuda"))
    ap.add_argument("--precision", default="float32", choices=("float32", "float64"))
    a = ap.parse_args()
    print(host())
    sim = setup(a.case, a.n, precision=a.precision, backend=a.backend)
    if a.backend == "cuda":
        report(*main_cuda(a, sim))
        return
    st = sim.state
    model, P, G = st.model, st.P, st.G
    f = model.view(st.fluid, model.fluid_view)
    w = model.view(st.walls, model.wall_view)
    dim, dtype, init, pair1, finish, pair2, _ = model._interaction_parts
    zero = np.dtype(dtype).type(0)
    n = st.fluid.n
    rc2 = float(P.rc2)
    r2 = dtype(rc2 * (1 + a.skin) ** 2)
    build = make_list_builder(dim, zero)
    lpass = make_list_pass(dim, init, pair1, pair2 if pair2 is not None else pair1, finish, zero)
    c1 = np.zeros(n, np.uint32)
    c2 = np.zeros(n, np.uint32)
    cap = 8
    while True:
        l1 = np.empty((n, cap), np.uint32)
        l2 = np.empty((n, cap), np.uint32)
        build(f, f, w, G, r2, c1, l1, c2, l2)
        if max(c1.max(), c2.max()) <= cap:
            break
        cap = int(max(c1.max(), c2.max()) * 1.2) + 1
    model.interaction(f, f, w, P, G)
    ref = (st.fluid["dvdt"].copy(), st.fluid.arrays.get("drhodt", st.fluid["rho"]).copy())
    lpass(f, f, w, P, c1, l1, c2, l2)
    got = (st.fluid["dvdt"], st.fluid.arrays.get("drhodt", st.fluid["rho"]))
    dv = float(np.max(np.abs(got[0] - ref[0])) / np.max(np.abs(ref[0])))
    dr = float(np.max(np.abs(got[1] - ref[1])) / max(np.max(np.abs(ref[1])), 1e-30))
    print(f"{a.case}: {n} fluid, {st.walls.n} wall particles, skin {a.skin} of the support; "
          f"list: {c1.mean():.1f} fluid + {c2.mean():.1f} wall neighbours a particle (cap {cap}); "
          f"list pass vs walk: largest difference {dv:.2e} (dv/dt), {dr:.2e} (drho/dt), relative")
    agree(max(dv, dr), dtype)
    walk_t, build_t, list_t = [], [], []
    for _ in range(a.rounds):
        t0 = time.perf_counter()
        model.interaction(f, f, w, P, G)
        t1 = time.perf_counter()
        build(f, f, w, G, r2, c1, l1, c2, l2)
        t2 = time.perf_counter()
        lpass(f, f, w, P, c1, l1, c2, l2)
        t3 = time.perf_counter()
        walk_t.append(t1 - t0)
        build_t.append(t2 - t1)
        list_t.append(t3 - t2)
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
