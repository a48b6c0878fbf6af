"""A stale Numba cache index is treated as empty instead of failing.

Numba's on-disk cache index pickles the argument types of each compiled loop, among them
wcsph's namedtuple views and parameter tuples, by module and name. After an upgrade that
renamed or moved one of them, unpickling an old index raises (``AttributeError: Can't get
attribute 'WallView'``, ``ModuleNotFoundError: wcsph.models.bi``) out of the first call of a
loop, a traceback for the user. Numba already treats an index of another Numba version as
empty and recompiles; this extends that to an index whose types no longer exist: the loop
is compiled again and the index rewritten.
"""
def install():
    try:
        from numba.core.caching import IndexDataCacheFile
    except ImportError:  # a Numba without this class: nothing to guard
        return
    load = IndexDataCacheFile._load_index
    if getattr(load, "_wcsph_guarded", False):
        return

    def _load_index(self):
        try:
            return load(self)
        except (AttributeError, ImportError, EOFError, ValueError):
            return {}

    _load_index._wcsph_guarded = True
    IndexDataCacheFile._load_index = _load_index
