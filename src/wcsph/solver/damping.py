"""Stage: damping zones (``[[damping]]``), where waves are absorbed at the end of a flume, as
DualSPHysics' damping zones absorb them. In a zone (a box) the fluid's velocity is relaxed
after each step by v <- v max(0, 1 - dt beta s^2), s in [0, 1] the distance into the zone along
its ``direction`` over the zone's length that way and beta its ``strength`` [1/s]: nothing at
the zone's entrance, the full rate at its far end, so a wave entering it is not reflected by a
jump in the damping."""
from collections import namedtuple

import numpy as np
from numba.extending import register_jitable

DampingParams = namedtuple("DampingParams", "lo0 lo1 lo2 hi0 hi1 hi2 e0 e1 e2 start length beta dt")
DampedFluid = namedtuple("DampedFluid", "x v")


def make_damping(dim):
    """The per-particle map of one zone (I: the fluid's x and v; P: ``DampingParams``)."""

    @register_jitable
    def damp(i, I, P):
        x, y = I.x[0, i], I.x[1, i]
        z = I.x[2, i] if dim == 3 else P.lo2
        if P.lo0 <= x < P.hi0 and P.lo1 <= y < P.hi1 and (dim == 2 or P.lo2 <= z < P.hi2):
            d = x * P.e0 + y * P.e1 + (z * P.e2 if dim == 3 else 0.0)
            s = min(max((d - P.start) / P.length, 0.0), 1.0)
            f = max(1.0 - P.dt * P.beta * s * s, 0.0)
            for a in range(dim):
                I.v[a, i] = I.v[a, i] * f

    return damp


class Damping:
    def __init__(self, backend, dim, zones):
        self.map = backend.make_map(make_damping(dim))
        self.zones = []
        for z in zones:
            lo, hi = np.asarray(z["min"], dtype=float), np.asarray(z["max"], dtype=float)
            e = np.asarray(z["direction"] or [1.0] + [0.0] * (dim - 1), dtype=float)
            e = e / np.linalg.norm(e)
            corners = np.array(np.meshgrid(*zip(lo, hi), indexing="ij")).reshape(dim, -1)
            d = e @ corners  # the zone's extent along its direction
            pad = [0.0] * (3 - dim)
            self.zones.append((list(lo) + pad, list(hi) + pad, list(e) + pad, float(d.min()),
                               float(d.max() - d.min()), float(z["strength"])))

    def __call__(self, state):
        f = state.fluid
        if not f.n:
            return
        view = DampedFluid(f["x"], f["v"])
        dt = state.dtype
        for lo, hi, e, start, length, beta in self.zones:
            self.map(view, DampingParams(*(dt(v) for v in (*lo, *hi, *e, start, length, beta, state.dt))))
