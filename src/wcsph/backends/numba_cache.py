"""Numba's on-disk cache made safe for several processes and for upgrades.

**Processes.** Numba saves a compiled loop by reading the cache index, taking the first free
data-file number, writing the index and then the data, with no lock. Two processes that
compile two loops of one source at once (the closures of ``make_pass`` and ``make_map``
share one index: MPI ranks on a node, pytest-xdist workers) both take number 1: the index
that is written last names one loop, the data file written last holds the other, and a
third process then loads the other loop's machine code under the first one's key: a wrong
answer without an error (seen as a restart that was no longer bit for bit, in three of
three cold runs of the restart tests on two workers). Here a save holds an exclusive lock
on the index, reads the index again under it, writes the data before the index names it,
and a load holds a shared lock while it reads the index and the data. Where no lock can
be taken (no ``fcntl``, a read-only cache directory) Numba's own behaviour is kept.

**Upgrades.** Numba's index pickles the argument types of each compiled loop, among them
wcsph's namedtuple views and parameter tuples, by module and name. After an upgrade that
renamed or moved one of them, unpickling an old index raises (``AttributeError: Can't get
attribute 'WallView'``, ``ModuleNotFoundError: wcsph.models.bi``) out of the first call of a
loop, a traceback for the user. Numba already treats an index of another Numba version as
empty and recompiles; this extends that to an index whose types no longer exist: the loop
is compiled again and the index rewritten.
"""
import itertools
from contextlib import contextmanager

try:
    import fcntl
except ImportError:  # not POSIX: Numba's unlocked cache
    fcntl = None


@contextmanager
def _locked(index_path, exclusive):
    """Hold a lock on ``index_path``'s lock file (exclusive or shared); nothing when none
    can be taken."""
    f = None
    if fcntl is not None:
        try:
            f = open(index_path + ".lock", "a+b")
            fcntl.flock(f, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        except OSError:
            if f is not None:
                f.close()
            f = None
    try:
        yield
    finally:
        if f is not None:
            f.close()  # releases the lock


def install():
    try:
        from numba.core.caching import IndexDataCacheFile
    except ImportError:  # a Numba without this class: nothing to guard
        return
    if getattr(IndexDataCacheFile.save, "_wcsph_guarded", False):
        return
    load_index = IndexDataCacheFile._load_index

    def _load_index(self):
        try:
            return load_index(self)
        except (AttributeError, ImportError, EOFError, ValueError):
            return {}

    def save(self, key, data):
        with _locked(self._index_path, exclusive=True):
            overloads = self._load_index()
            name = overloads.get(key)
            if name is None:
                taken = set(overloads.values())
                name = next(n for n in (self._data_name(i) for i in itertools.count(1)) if n not in taken)
            self._save_data(name, data)  # before the index names it
            if overloads.get(key) != name:
                overloads[key] = name
                self._save_index(overloads)

    load = IndexDataCacheFile.load

    def locked_load(self, key):
        with _locked(self._index_path, exclusive=False):
            return load(self, key)

    for f in (_load_index, save, locked_load):
        f._wcsph_guarded = True
    IndexDataCacheFile._load_index = _load_index
    IndexDataCacheFile.save = save
    IndexDataCacheFile.load = locked_load
