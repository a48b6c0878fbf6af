"""The part of the neighbour loop both backends share: folding one contiguous run of
sorted particles j0..j1 of set J into particle i's accumulator."""
import math

from numba.extending import register_jitable


def make_run_visitor(dim, pair, zero, inline="never"):
    """``visit(i, xi, yi, zi, I, J, j0, j1, P, acc)``: apply ``pair`` to every j in
    [j0, j1) within the support radius (``P.rc2``). j0 and j1 come from the unsigned cell
    offsets, so j is unsigned and Numba emits no negative-index wrap-around code. The CPU
    loop asks for ``inline="always"`` (a separate function costs it 20 %); numba-cuda does not
    compile that form, and its own inliner needs no help."""

    @register_jitable(inline=inline)
    def visit(i, xi, yi, zi, I, J, j0, j1, P, acc):
        for j in range(j0, j1):
            dx = xi - J.x[0, j]
            dy = yi - J.x[1, j]
            dz = zi - J.x[2, j] if dim == 3 else zero
            r2 = dx * dx + dy * dy + dz * dz
            if r2 < P.rc2:
                acc = pair(i, j, dx, dy, dz, math.sqrt(r2), I, J, P, acc)
        return acc

    return visit
