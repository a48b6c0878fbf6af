"""The fluid sampled at points: the Shepard sums of its fields around each point, one pass
over the points with their fluid neighbours. Pressure sensors and level gauges (``probes``),
the open boundaries' mirror points (``open_boundary``) and whatever else reads the fluid
between particles use this one sampler.

For points x_s and fluid neighbours j (V_j = m_j / rho_j) the sums are

* ``w``: sum_j W_sj V_j (about 1 inside the fluid, 1/2 on a wall, 0 in the air);
* ``rho``, ``p``, ``v``: sum_j f_j W_sj V_j, which divided by ``w`` are the Shepard means;
* ``c``: sum_j rho_j (g - Dv/Dt_j) . (x_s - x_j) W_sj V_j, the pressure each neighbour's own
  gradient (the momentum equation's) adds on the way to x_s: (p + c) / w is the pressure
  carried to the point, Adami et al.'s (2012) wall pressure in still water.
"""
from collections import namedtuple

import numpy as np
from numba.extending import register_jitable

from ..backends.particles import ParticleSet

SamplePoints = namedtuple("SamplePoints", "x sum_w sum_rho sum_p sum_c sum_v cell start")
SampleFluid = namedtuple("SampleFluid", "x v rho p m dvdt cell start")
#: ... with the open boundaries' ``kind`` (buffer particles skipped)
SampleFluidKind = namedtuple("SampleFluidKind", "x v rho p m dvdt kind cell start")


def make_sample_pass(ctx, backend, periodic, skip_buffers):
    """The pass over points I with fluid neighbours J that writes the sums above; with
    ``skip_buffers`` the open boundaries' buffer particles (``kind`` != 0) are not neighbours."""
    w, zero, dim = ctx.w, ctx.zero, ctx.dim

    @register_jitable
    def init(i, I, P):
        return (zero, zero, zero, zero, zero, zero, zero)

    @register_jitable
    def pair(i, j, dx, dy, dz, r, I, J, P, acc):
        if skip_buffers:
            if J.kind[j] != 0:
                return acc
        wv = w(r, P) * J.m[j] / J.rho[j]
        # grad p = rho (g - Dv/Dt) at j (the momentum equation), times x_s - x_j
        gz = (P.gz - J.dvdt[2, j]) * dz if dim == 3 else zero
        c = J.rho[j] * ((P.gx - J.dvdt[0, j]) * dx + (P.gy - J.dvdt[1, j]) * dy + gz)
        vz = J.v[2, j] * wv if dim == 3 else zero
        return (acc[0] + wv, acc[1] + J.rho[j] * wv, acc[2] + J.p[j] * wv, acc[3] + c * wv,
                acc[4] + J.v[0, j] * wv, acc[5] + J.v[1, j] * wv, acc[6] + vz)

    @register_jitable
    def store(i, I, P, acc):
        I.sum_w[i] = acc[0]
        I.sum_rho[i] = acc[1]
        I.sum_p[i] = acc[2]
        I.sum_c[i] = acc[3]
        I.sum_v[0, i] = acc[4]
        I.sum_v[1, i] = acc[5]
        if dim == 3:
            I.sum_v[2, i] = acc[6]

    return backend.make_pass(dim, ctx.dtype, init, pair, store, periodic=periodic)


class PointSampler:
    """Shepard sums of the fluid at points (``sums``). Fixed points (``points`` given) are
    sorted into the grid once; points that change are passed to ``sums`` each time."""

    def __init__(self, state, points=None, skip_buffers=False):
        from ..physics import Ctx

        self.state = state
        self.skip_buffers = skip_buffers
        ctx = Ctx.create(state.dtype, state.dim, state.case["model"]["kernel"])
        self._pass = make_sample_pass(ctx, state.backend, state.model.periodic, skip_buffers)
        self._fixed = None if points is None else self._point_set(points)

    def _point_set(self, points):
        """(the points as a sorted particle set, the order that restores the caller's)."""
        be, dt, state = self.state.backend, self.state.dtype, self.state
        s = ParticleSet("points", state.dim, {"x": be.to_device(np.asarray(points).astype(dt))})
        for name in ("sum_w", "sum_rho", "sum_p", "sum_c"):
            s.add(name, "scalar", dt, be)
        s.add("sum_v", "vector", dt, be)
        s["order"] = be.to_device(np.arange(s.n, dtype=np.int64))
        if be.sort(s, state.grid):  # a point outside the grid would shift every later one
            raise RuntimeError("a sample point lies outside the cell grid")
        return s, np.argsort(be.to_host(s["order"]))

    def sums(self, points=None):
        """{"w", "rho", "p", "c": (n,), "v": (dim, n)} in float64, in the points' order, from
        the fluid's current state and cell list (a sample between steps: positions have moved
        by far less than a cell since the sort)."""
        s, order = self._fixed if points is None else self._point_set(points)
        state = self.state
        fl = state.fluid
        cls = SampleFluidKind if self.skip_buffers else SampleFluid
        J = cls._make(fl[f] for f in cls._fields)
        self._pass(s.view(SamplePoints), J, J, state.P, state.G)
        host = state.backend.to_host
        return {k: host(s["sum_" + k]).astype(float)[..., order] for k in ("w", "rho", "p", "c", "v")}
