"""The uniform cell grid of the neighbour search.

Cell size equals the kernel support, so a particle's neighbours lie in its own and the
adjacent cells. One layer of empty ghost cells surrounds the domain: every real cell then
has all its neighbour cells inside the grid, and the loop needs no bounds tests. Cells are
numbered x fastest, so the three cells (cx-1..cx+1, cy, cz) hold one contiguous run of
sorted particles. The extra cell id ``ncells`` collects particles that left the domain;
sorting puts them last, where the driver drops them (as DualSPHysics excludes them).
"""
from collections import namedtuple
from dataclasses import dataclass

import numpy as np

#: integer grid description passed to compiled loops
GridView = namedtuple("GridView", "nx ny nz sy sz ncells")


@dataclass
class Grid:
    dim: int
    origin: np.ndarray  # lower corner of the ghost layer
    cell_size: float
    shape: tuple  # cells per axis, ghosts included; 1 in z for 2D

    @classmethod
    def covering(cls, lo, hi, cell_size):
        lo = np.asarray(lo, dtype=float)
        hi = np.asarray(hi, dtype=float)
        dim = lo.size
        n = np.maximum(np.ceil((hi - lo) / cell_size).astype(int), 1) + 2
        shape = tuple(int(v) for v in n) + ((1,) if dim == 2 else ())
        return cls(dim, lo - cell_size, float(cell_size), shape)

    @property
    def ncells(self):
        return int(np.prod(self.shape))

    def view(self):
        nx, ny, nz = self.shape
        return GridView(np.int64(nx), np.int64(ny), np.int64(nz), np.int64(nx),
                        np.int64(nx * ny), np.int64(self.ncells))

    def geometry(self, dtype):
        """Origin and inverse cell size in the working dtype, for the cell-index kernel."""
        o = np.zeros(3, dtype=dtype)
        o[: self.dim] = self.origin
        return o, dtype(1.0 / self.cell_size)
