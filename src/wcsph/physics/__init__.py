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
        from .kernels import make_kernel

        dtype = np.dtype(dtype).type
        return cls(dtype, dim, *make_kernel(kernel, dtype))


class AfterStepPass:
    """A pass made after each time step (or every ``every`` steps): a pass over fluid
    neighbours (``fluid``) and wall neighbours (``wall``, or None) from ``init`` to ``store``,
    which writes the particle's correction into a scratch field (``corr``, a vector, or
    ``rho_corr``) so that no particle moves while its neighbours read it; then the map
    ``apply`` adds it to the state. ``dt`` in P is the step just taken."""

    def __init__(self, init, fluid, store, apply, wall=None, every=1):
        self.init, self.fluid, self.store, self.apply, self.wall, self.every = init, fluid, store, apply, wall, every


class WallPass:
    """A pass over the wall points with fluid neighbours, made before each interaction (the
    wall's no-slip velocity, its pressure, the consistent elements' p and rho): from ``init``
    to ``store``, which writes the wall fields ``writes`` ((name, kind) pairs; the wall set
    holds them, a decomposed run refreshes them on its walls) and reads the wall fields
    ``reads`` besides x and v. ``velocity``: it writes
    ``v_ext``, which the later wall terms read as the wall's velocity (its view is x, v,
    v_ext). ``loads``: it is made again before the wall loads (``model.wall_loads``)."""

    def __init__(self, init, pair, store, writes, reads=(), velocity=False, loads=False):
        self.init, self.pair, self.store, self.writes = init, pair, store, tuple(writes)
        self.reads, self.velocity, self.loads = tuple(reads), velocity, loads


class FluidPass:
    """A pass over the fluid with fluid neighbours (``fluid``) and wall neighbours (``wall``,
    or None), made before each interaction (CSPM's correction matrix, the sub-particle-scale
    stress); its store writes a fluid field the interaction reads. ``writes``: the fields
    the interaction reads of a neighbour, which a decomposed run refreshes on its ghosts
    after the pass (CSPM reads its L of particle i only: none)."""

    def __init__(self, init, fluid, store, wall=None, writes=()):
        self.init, self.fluid, self.store, self.wall = init, fluid, store, wall
        self.writes = tuple(writes)


class WallCorrection:
    """A pass over the fluid with wall neighbours only, made after each time step, after the
    ``AfterStepPass`` es (the elastic bounce and NBVC-PST of boundary elements): its store
    writes the particle's velocity and position itself (each particle reads only walls)."""

    def __init__(self, init, pair, store):
        self.init, self.pair, self.store = init, pair, store


class WallVolume:
    """The pass that gives each boundary particle its pseudo-mass Psi at the start: over wall
    neighbours, from ``init`` to ``store`` (which writes ``psi``)."""

    def __init__(self, init, pair, store):
        self.init, self.pair, self.store = init, pair, store


def vector_init(ctx):
    zero = ctx.zero

    @register_jitable
    def init(i, I, P):
        return (zero, zero, zero)

    return init


def make_store_corr(ctx):
    """Store a (cx, cy, cz) accumulator into ``corr``."""
    dim = ctx.dim

    @register_jitable
    def store(i, I, P, acc):
        I.corr[0, i] = acc[0]
        I.corr[1, i] = acc[1]
        if dim == 3:
            I.corr[2, i] = acc[2]

    return store


def make_apply(ctx, field, scale_dt):
    """``field`` (``x`` or ``v``) += corr (times P.dt with ``scale_dt``). Two functions, not a
    getter of the field: numba-cuda does not return an array a device function did not take
    as an argument."""
    dim, one = ctx.dim, ctx.dtype(1)
    if field == "x":
        @register_jitable
        def apply(i, I, P):
            k = P.dt if scale_dt else one
            for d in range(dim):
                I.x[d, i] += k * I.corr[d, i]
    else:
        @register_jitable
        def apply(i, I, P):
            k = P.dt if scale_dt else one
            for d in range(dim):
                I.v[d, i] += k * I.corr[d, i]

    return apply
