"""The parts of the loops both backends share: folding one contiguous run of sorted
particles j0..j1 of set J into particle i's accumulator, and the check of one particle."""
import math

import numpy as np

from numba.extending import register_jitable


def make_particle_check(inline="never"):
    """check(x, v, a, i) = (|v|^2, |a|^2, ok) of particle i of the (dim, N) arrays x, v, a: ok
    when all three are finite (the check after a step; compiled without fastmath, which would
    drop the test). Each square is made in the arrays' precision and summed in float64 in the
    order of the components; x's finiteness is read from the sum of its components (a
    non-finite component makes it non-finite). ``inline="always"``: Numba's own inlining,
    for the CPU's loop, where a call left to LLVM kept the loop from vectorising (0.21 against
    1.7 ms at 98 k particles in 2D, measured alone); the CUDA kernels take the plain form
    (numba-cuda's pipeline does not take the CPU's inliner)."""
    @register_jitable(inline=inline)
    def particle_check(x, v, a, i):
        s = np.float64(v[0, i] * v[0, i]) + np.float64(v[1, i] * v[1, i])
        q = np.float64(a[0, i] * a[0, i]) + np.float64(a[1, i] * a[1, i])
        r = np.float64(x[0, i]) + np.float64(x[1, i])
        if x.shape[0] == 3:
            s += np.float64(v[2, i] * v[2, i])
            q += np.float64(a[2, i] * a[2, i])
            r += np.float64(x[2, i])
        return s, q, math.isfinite(s) and math.isfinite(q) and math.isfinite(r)

    return particle_check


#: the check of one particle, as the CUDA check calls it
particle_check = make_particle_check()


@register_jitable
def every(i, I, P):
    """The ``keep`` of a pass that visits every particle of its set."""
    return True


@register_jitable
def body_term(x, load, refs, i, r, comp):
    """Wall point i's share of row r of a body-load sum (``backend.body_sums``): its load
    along axis ``comp`` (0-2), or its torque about the body's reference point refs[r] about
    axis comp - 3 (3-5; in 2D only 5, the torque about z, is not zero)."""
    dim = x.shape[0]
    if comp < dim:
        return float(load[comp, i])
    if comp < 3:
        return 0.0
    rx = float(x[0, i]) - refs[r, 0]
    ry = float(x[1, i]) - refs[r, 1]
    fx = float(load[0, i])
    fy = float(load[1, i])
    if dim == 2:
        return rx * fy - ry * fx if comp == 5 else 0.0
    rz = float(x[2, i]) - refs[r, 2]
    fz = float(load[2, i])
    if comp == 3:
        return ry * fz - rz * fy
    if comp == 4:
        return rz * fx - rx * fz
    return rx * fy - ry * fx


def make_run_visitor(dim, pair, zero, inline="never", branchless=False):
    """``visit(i, xi, yi, zi, I, J, j0, j1, P, acc)``: apply ``pair`` to every j in
    [j0, j1) within the support radius (``P.rc2``). j0 and j1 come from the unsigned cell
    offsets, so j is unsigned and Numba emits no negative-index wrap-around code. The CPU
    loop asks for ``inline="always"`` (a separate function costs it 20 %); numba-cuda does not
    compile that form, and its own inliner needs no help.

    ``branchless``: evaluate ``pair`` for every candidate and keep its result only within the
    support (a select instead of a branch; a value computed beyond the support, even a NaN,
    is discarded). The loads then no longer sit behind a branch and the loop vectorises. It
    pays where the pair terms are heavy and the candidates few, and costs where they are
    light: measured at 100 k particles, the 2D WCSPH-BI interaction pass 10.7 -> 8.4 ms, but
    the classic force pass 9.1 -> 19.2 ms and the 3D WCSPH-BI pass (4.5 candidates per
    neighbour) 64.8 -> 72.2 ms."""

    @register_jitable(inline=inline)
    def visit(i, xi, yi, zi, I, J, j0, j1, P, acc):
        for j in range(j0, j1):
            dx = xi - J.x[0, j]
            dy = yi - J.x[1, j]
            dz = zi - J.x[2, j] if dim == 3 else zero
            r2 = dx * dx + dy * dy + dz * dz
            if branchless:  # a compile-time choice: Numba prunes the other branch
                new = pair(i, j, dx, dy, dz, math.sqrt(r2), I, J, P, acc)
                acc = new if r2 < P.rc2 else acc
            elif r2 < P.rc2:
                acc = pair(i, j, dx, dy, dz, math.sqrt(r2), I, J, P, acc)
        return acc

    return visit


def make_periodic_walk(dim, visit1, visit2, use2, zero, periodic, inline="never"):
    """``walk(i, xi, yi, zi, c, I, J1, J2, P, G, acc)``: the cells within k of cell c of a
    grid with periodic axes (``periodic``: a compile-time flag per axis). A neighbour cell
    beyond a periodic side is its image on the other side, k..k+n-1 the real cells: its
    particles are visited with i's position shifted by the length L of the box (x_i + L
    below the lower side, x_i - L above the upper), so that dx = x_i - x_j is the distance to
    the nearest image. Along a periodic x axis a run of cells that crosses the side is walked
    cell by cell; elsewhere it is one run, as in the plain loop."""
    px = periodic[0]
    py = periodic[1]
    pz = periodic[2] if len(periodic) > 2 else False
    ftype = type(zero)

    @register_jitable(inline=inline)  # numba-cuda cannot compile Numba's inlined form
    def image(r, pos, k, n, length):
        """Cell index r along a periodic axis of n real cells (k..k+n-1) and i's coordinate
        there: a ghost cell becomes its image, the coordinate shifted by the length."""
        if r < k:
            return r + n, pos + ftype(length)
        if r >= k + n:
            return r - n, pos - ftype(length)
        return r, pos

    @register_jitable(inline=inline)
    def walk(i, xi, yi, zi, c, I, J1, J2, P, G, acc):
        k = G.k
        kz = k if dim == 3 else 0
        cx = c % G.nx
        cy = (c // G.nx) % G.ny
        cz = c // G.sz
        for oz in range(-kz, kz + 1):
            rz, zs = cz + oz, zi
            if pz:
                rz, zs = image(rz, zi, k, G.rz, G.Lz)
            for oy in range(-k, k + 1):
                ry, ys = cy + oy, yi
                if py:
                    ry, ys = image(ry, yi, k, G.ry, G.Ly)
                row = ry * G.sy + rz * G.sz
                if px and (cx < 2 * k or cx >= G.rx):  # the run of 2k + 1 cells crosses a side
                    for ox in range(-k, k + 1):
                        rx, xs = image(cx + ox, xi, k, G.rx, G.Lx)
                        cc = row + rx
                        acc = visit1(i, xs, ys, zs, I, J1, J1.start[cc], J1.start[cc + 1], P, acc)
                        if use2:
                            acc = visit2(i, xs, ys, zs, I, J2, J2.start[cc], J2.start[cc + 1], P, acc)
                else:
                    cc = row + cx
                    acc = visit1(i, xi, ys, zs, I, J1, J1.start[cc - k], J1.start[cc + k + 1], P, acc)
                    if use2:
                        acc = visit2(i, xi, ys, zs, I, J2, J2.start[cc - k], J2.start[cc + k + 1], P, acc)
        return acc

    return walk
