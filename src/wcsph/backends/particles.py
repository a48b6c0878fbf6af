"""Particle sets as structure-of-arrays.

A set is a dict of named arrays: vectors are stored as (dim, N) arrays, one contiguous row
per component, scalars as (N,) arrays. ``cell`` and ``start`` hold the cell list. The
compiled loops see a set through a namedtuple ("view") whose fields a model chooses; the
loop itself only needs ``x``, ``cell`` and ``start``.
"""
import numpy as np


class ParticleSet:
    def __init__(self, name, dim, arrays):
        self.name = name
        self.dim = dim
        self.arrays = dict(arrays)
        self._sorted = None  # sorted_fields(), kept until a field is added or n changes
        self.n = self.arrays["x"].shape[1]
        self.scratch = set()  # fields recomputed before they are read: sorting skips them

    @property
    def n(self):
        return self._n

    @n.setter
    def n(self, value):
        self._n = value
        self._sorted = None

    def __getitem__(self, key):
        return self.arrays[key]

    def __setitem__(self, key, value):
        if key not in self.arrays:
            self._sorted = None
        self.arrays[key] = value

    def add(self, key, shape_kind, dtype, backend, fill=0.0, scratch=False):
        """Add a per-particle field: ``shape_kind`` 'scalar', 'vector' or a tuple of leading
        dimensions (an integrator's stages: (stages, components)). A ``scratch`` field
        is written by every step before anything reads it (derivatives, EOS values, an
        integrator's saved copies), so sorting need not carry it to the new order."""
        if isinstance(shape_kind, tuple):
            shape = tuple(shape_kind) + (self.n,)
        else:
            shape = (self.n,) if shape_kind == "scalar" else (self.dim, self.n)
        self.arrays[key] = backend.to_device(np.full(shape, fill, dtype=dtype))
        self._sorted = None
        if scratch:
            self.scratch.add(key)

    def per_particle(self):
        """Names of the arrays indexed by particle (reordered when particles are sorted)."""
        return [k for k, a in self.arrays.items()
                if k != "start" and not k.startswith("_") and a.shape[len(a.shape) - 1] == self.n]

    def sorted_fields(self):
        """The per-particle arrays a sort must reorder: all but the scratch fields."""
        if self._sorted is None:
            self._sorted = [k for k in self.per_particle() if k not in self.scratch]
        return self._sorted

    def view(self, cls):
        return cls(**{f: self.arrays[f] for f in cls._fields})
