"""Fields on grids (``[[grids]]``): p, rho and v of the fluid interpolated at the nodes of a
line, plane or box (Shepard means, ``io.sampling``), written at the grid's own rate as a VTK
image series ``grid_NAME.pvd`` of ``grid_NAME_NNNN.vti`` frames, as DualSPHysics' MeasureTool
and TNL-SPH's interpolation planes write them. A node whose kernel sum sum_j W V_j is below
``DRY`` (no fluid within reach) reads 0; ``kernel_sum`` is written too (1 inside the fluid,
1/2 at its free surface, 0 in the air)."""
import numpy as np

from ..errors import CaseError
from ..physics.loads import DRY
from .sampling import PointSampler
from .vtk import write_image


class GridSampler:
    """One ``[[grids]]`` table: its nodes, sampled on demand (``write``)."""

    def __init__(self, state, spec, key):
        self.state, self.spec, self.name = state, spec, spec["name"]
        dim = state.dim
        origin = np.asarray(spec["origin"], dtype=float)
        self.origin = np.zeros(3)
        self.origin[:dim] = origin
        self.spacing = np.ones(3)
        self.counts = [1, 1, 1]
        ticks = [np.zeros(1)] * dim
        for a, n in zip(spec["axes"], spec["counts"]):
            c = int(np.flatnonzero(a)[0])
            self.counts[c] = n
            self.spacing[c] = a[c] / (n - 1)
            ticks[c] = a[c] * np.linspace(0.0, 1.0, n)
        mesh = np.meshgrid(*[origin[c] + ticks[c] for c in range(dim)], indexing="ij")
        nodes = np.stack([m.ravel(order="F") for m in mesh])  # x fastest, as an image
        lo, hi = state.domain
        outside = np.any((nodes < lo[:, None]) | (nodes >= hi[:, None]), axis=0)
        if outside.any():
            bad = nodes[:, np.flatnonzero(outside)[0]]
            raise CaseError(f"{state.case['_source']}: {key}: the node {np.round(bad, 6).tolist()} lies outside "
                            f"the domain {np.round(lo, 6).tolist()} .. {np.round(hi, 6).tolist()}")
        self.nodes = nodes
        self.sampler = PointSampler(state, nodes)

    def fields(self):
        """{"p", "rho", "kernel_sum": (n,), "v": (3, n)} at the nodes, float32 (rank 0 of a
        decomposed run holds the totals)."""
        state = self.state
        state.settle()
        s = self.sampler.sums()
        w, rho, p, v = s["w"], s["rho"], s["p"], s["v"]
        par = state.par
        if par is not None:  # each node from the rank whose slab holds it
            mine = par.owner(par.column(self.nodes)) == par.rank
            total = par.sum(np.concatenate([np.stack([w, rho, p]), v]) * mine)
            w, rho, p, v = total[0], total[1], total[2], total[3:]
        wet = w >= DRY
        inv = np.where(wet, 1.0 / np.where(wet, w, 1.0), 0.0)
        v3 = np.zeros((3, w.size))
        v3[: state.dim] = v * inv
        return {"p": (p * inv).astype(np.float32), "rho": (rho * inv).astype(np.float32),
                "v": v3.astype(np.float32), "kernel_sum": w.astype(np.float32)}

    def write(self, path, fields):
        write_image(path, self.origin, self.spacing, self.counts, fields)
