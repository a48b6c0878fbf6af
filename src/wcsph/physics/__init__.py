"""Physics terms: small jitable functions of one particle (EOS) or one particle pair.

A pair term has the signature ``term(i, j, dx, dy, dz, r, I, J, P, acc) -> acc``: particle
i of set I, neighbour j of set J, (dx, dy, dz) = x_i - x_j, r = |x_i - x_j| < support, P the
parameter tuple, acc the accumulator tuple of the pass. Terms are built by factories that
take a ``Ctx`` (dtype, dimension, kernel), and ``compose`` chains several into one.
"""
from dataclasses import dataclass
from functools import reduce

import numpy as np

from numba.extending import register_jitable


def _chain(f, g):
    @register_jitable
    def both(i, j, dx, dy, dz, r, I, J, P, acc):
        return g(i, j, dx, dy, dz, r, I, J, P, f(i, j, dx, dy, dz, r, I, J, P, acc))

    return both


def compose(*terms):
    """One pair function applying ``terms`` in order to the same accumulator."""
    return reduce(_chain, terms)


@dataclass(frozen=True)
class Ctx:
    """What a term factory may close over: compile-time choices only, never case values
    (those travel in ``P`` so that one compiled loop serves every case)."""

    dtype: type
    dim: int
    w: object
    grad: object

    @property
    def zero(self):
        return self.dtype(0)

    @classmethod
    def create(cls, dtype, dim, kernel):
        from ..kernels import make_kernel

        dtype = np.dtype(dtype).type
        return cls(dtype, dim, *make_kernel(kernel, dtype))
