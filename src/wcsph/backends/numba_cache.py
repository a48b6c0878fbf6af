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
is compiled again and the index rewritten. A save that fails (a full disk, a cache directory
that went read-only during the run) is skipped: the loop runs as compiled, and the next
process compiles it again; Numba's own save raised out of the run's first step.

**Names.** Numba names a compiled function after its qualified name and a number from a
counter of the process (``FunctionIdentity.unique_id``), and the machine code it caches keeps
those names. The closures of one factory (``make_place(dim, normals)``, the loops of
``make_map``) share a qualified name and, for one argument type, differ only in that
number: two processes that compiled two of them (the 2D and the 3D wall placement) could
give both the same number, and a process that loaded both from the cache (the test suite,
``wcsph validate``: 2D and 3D cases in one process) linked both definitions under one name,
and one of them ran for the other (seen as the 3D placement writing a third row into a 2D
set: a heap corrupted, a run stopped with a false message or hung). Here a closure's number
is made from what it is: its code and the contents of its cells (``_content_id``), the same
in every process for the same closure and different for different ones; a function without
a closure, or whose cells cannot be pickled, keeps Numba's counter.

**Sources.** Numba keeps a cached function while its own file is unchanged (its timestamp
and size): a helper it calls from another file (``walk.make_particle_check`` under
``cpu._check``) may change and the cached caller still runs the old code, in a working tree
where one file was edited (seen: a benchmark read the old helper's figures until the cache
was removed). Here a function of this package is stamped with the package's sources as
well (``package_stamp``: every ``.py`` file's path, timestamp and size), so an edit anywhere
in it compiles its loops again; a clean checkout or an install is cold either way.

**Variants.** A loop compiled without ``parallel`` (``cpu._loop``, in a process of one
thread) shares the Python function, its closure and so Numba's key and JIT name with the
parallel loop of the same pass: its ``VARIANT`` is added to both (``_key_with_variant``,
``_content_id``), so that a process of one thread never loads the parallel loop a process of
several saved, nor the other way round.

**Compiled or loaded.** A cached ``parallel=True, fastmath=True`` loop ran other machine code
in the process that compiled it than in every process that loaded it (``saved_first``): a
restart, or a second run in one process, was then not bit for bit the run before it.
"""
import functools
import hashlib
import itertools
import marshal
import os
from contextlib import contextmanager
from functools import cached_property

from numba.core import sigutils
from numba.core.codegen import JITCPUCodegen
from numba.core.registry import CPUDispatcher, CPUTarget, cpu_target

try:
    import fcntl
except ImportError:  # not POSIX: Numba's unlocked cache
    fcntl = None


@contextmanager
def _holding(path, lock):
    """Hold ``lock(f)`` on the file ``path`` (opened for appending) until the block ends;
    nothing when no lock can be taken (no ``fcntl``, a read-only directory)."""
    f = None
    if fcntl is not None:
        try:
            f = open(path, "a+b")
            lock(f)
        except OSError:
            if f is not None:
                f.close()
            f = None
    try:
        yield
    finally:
        if f is not None:
            f.close()  # releases the lock


def _locked(index_path, exclusive):
    """Hold a lock on ``index_path``'s lock file (exclusive or shared)."""
    return _holding(index_path + ".lock", lambda f: fcntl.flock(f, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH))


#: the attribute of a Python function that names its compiled variant (``"serial"``: a loop
#: compiled without ``parallel``, ``cpu._loop``): part of its cache key and of its JIT name,
#: so that the two variants of one function neither load nor link as each other
VARIANT = "_wcsph_variant"


def _content_id(func):
    """A number for a closure from its code, its cells' contents and its ``VARIANT`` (None
    when it has no closure or they cannot be pickled): equal closures get equal numbers in
    every process."""
    closure = getattr(func, "__closure__", None)
    if not closure:
        return None
    try:
        from numba.core.serialize import dumps

        cells = dumps(tuple(c.cell_contents for c in closure))
        code = marshal.dumps(func.__code__)
    except Exception:  # an unpicklable cell, an empty one: Numba's counter
        return None
    variant = getattr(func, VARIANT, "").encode()
    return int(hashlib.sha256(code + cells + variant).hexdigest()[:15], 16)


def _key_with_variant():
    """Numba's cache key of a function, with its ``VARIANT`` where it has one."""
    try:
        from numba.core.caching import Cache
    except ImportError:
        return
    if getattr(Cache._index_key, "_wcsph_guarded", False):
        return
    own = Cache._index_key

    def _index_key(self, sig, codegen):
        key = own(self, sig, codegen)
        variant = getattr(self._py_func, VARIANT, None)
        return key if variant is None else key + (variant,)

    _index_key._wcsph_guarded = True
    Cache._index_key = _index_key


def _name_closures_by_content():
    try:
        from numba.core.bytecode import FunctionIdentity
    except ImportError:
        return
    made = FunctionIdentity.from_function.__func__
    if getattr(made, "_wcsph_named", False):
        return

    def from_function(cls, pyfunc):
        self = made(cls, pyfunc)
        uid = _content_id(self.func)
        if uid is not None:
            self.unique_id = uid
            self.unique_name = f"{self.func_qualname}${uid}"
        return self

    def derive(self):  # a copy that must differ (a lifted loop): Numba's counter, as before
        return made(type(self), self.func)

    from_function._wcsph_named = True
    FunctionIdentity.from_function = classmethod(from_function)
    FunctionIdentity.derive = derive


#: the package whose functions ``package_stamp`` stamps
PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@functools.lru_cache(maxsize=None)
def package_stamp(root=PACKAGE):
    """A digest of the sources under ``root``: each ``.py`` file's path, timestamp and size (as
    Numba stamps one file), read once per process."""
    h = hashlib.sha1()
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")  # walked in this order
        for f in sorted(f for f in files if f.endswith(".py")):
            path = os.path.join(folder, f)
            st = os.stat(path)
            h.update(f"{os.path.relpath(path, root)}:{st.st_mtime_ns}:{st.st_size};".encode())
    return h.hexdigest()


def _stamp_with_package():
    """Numba's stamp of a source file, with ``package_stamp`` for a file of this package."""
    try:
        from numba.core.caching import _SourceFileBackedLocatorMixin as mixin
    except ImportError:  # a Numba without it: its own stamps
        return
    if getattr(mixin.get_source_stamp, "_wcsph_guarded", False):
        return
    own = mixin.get_source_stamp

    def get_source_stamp(self):
        stamp = own(self)
        path = getattr(self, "_py_file", None)
        if path and os.path.abspath(path).startswith(PACKAGE + os.sep):
            return stamp, package_stamp()
        return stamp

    get_source_stamp._wcsph_guarded = True
    mixin.get_source_stamp = get_source_stamp


def _compiling(index_path, key):
    """Hold, for one cache key, an exclusive lock that a process takes before it compiles
    that key: a byte of ``index_path``'s ``.compile`` file picked by the key's digest (POSIX
    record locks, so that the compiles of different loops of one index do not wait for each
    other). A second process that wants the same loop meanwhile (MPI ranks on a node,
    pytest-xdist workers) waits here, then finds it in the cache and loads it instead of
    compiling it again."""
    where = int(hashlib.sha256(repr(key).encode()).hexdigest()[:8], 16) % (1 << 20)
    return _holding(index_path + ".compile", lambda f: fcntl.lockf(f, fcntl.LOCK_EX, 1, where))


def install():
    _name_closures_by_content()
    _key_with_variant()
    _stamp_with_package()
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
        try:
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
        except OSError:  # a full disk, a directory gone read-only: the loop runs, uncached
            pass

    load = IndexDataCacheFile.load

    def locked_load(self, key):
        with _locked(self._index_path, exclusive=False):
            return load(self, key)

    for f in (_load_index, save, locked_load):
        f._wcsph_guarded = True
    IndexDataCacheFile._load_index = _load_index
    IndexDataCacheFile.save = save
    IndexDataCacheFile.load = locked_load


class _TwinTarget(CPUTarget):
    """The CPU target with a JIT engine of its own: Numba's typing and implementations, a
    codegen of its own (as Numba's ahead-of-time compiler makes one), so that none of the
    symbols it compiles is found by code loaded into the main engine."""

    @cached_property
    def _toplevel_target_context(self):
        return cpu_target.target_context.subtarget(_internal_codegen=JITCPUCodegen("wcsph.twin"))

    @cached_property
    def _toplevel_typing_context(self):
        return cpu_target.typing_context


class _TwinDispatcher(CPUDispatcher):
    targetdescr = _TwinTarget("cpu")


def saved_first(run):
    """``run``, a cached parallel fastmath loop, made to run the machine code its cache holds
    in the process that compiles it too.

    Numba compiles the body of a parallel loop as a function of its own. The process that
    compiles the loop calls that function as it was compiled there; the cache holds the
    loop with the body linked into it and optimized once more, and under fastmath the two
    round differently. Measured: ``dam_break_2d_bi`` at dp = 0.02 in float32, 131 steps,
    the compiling process and a later one that loaded the same loops ended 2.3e-10 s apart
    in t, 2.5e-6 m/s in v and 2.4e-4 kg/m^3 in rho; without parallel or without fastmath
    they agree (numba/numba#10617 sees the two run at different speeds). So a second
    Simulation in one process, or a restart, ran other code than the first whenever the
    first had compiled.

    Here a signature the cache lacks is first compiled and saved by a twin dispatcher of
    the same function, in a JIT engine of its own, and ``run`` then loads it like any later
    process: every process runs the cached code, the first included. The twin compiles
    under the key's lock (``_compiling``): a process that wants a loop another is compiling
    waits for it and loads it, instead of compiling it too. A cold compile costs
    the same (the twin compiles, ``run`` only loads: 26.9 s against 28.1 s before for that
    case). Where the cache cannot be written, or Numba's cache internals differ, ``run``
    compiles as before."""
    options = dict(run.targetoptions)

    def save(sig):
        twin = _TwinDispatcher(run.py_func, targetoptions=options)
        twin.enable_caching()
        twin.compile(sig)

    return _compiled_once(run, save)


def compiled_once(run):
    """``run``, a cached function (not a parallel fastmath loop: ``saved_first``), compiled
    under its key's lock (``_compiling``): a process that wants it while another compiles it
    waits and loads it from the cache."""
    return _compiled_once(run, run.compile)


def _compiled_once(run, save):
    """``run`` whose compile of a signature the cache lacks first calls ``save(sig)`` under
    the key's lock, unless another process saved it meanwhile, then compiles or loads as
    Numba does. Where the cache cannot be written, or Numba's cache internals differ, ``run``
    compiles as before."""
    original = run.compile

    def compile(sig):
        try:
            args, _ = sigutils.normalize_signature(sig)
            cache = run._cache
            missing = tuple(args) not in run.overloads
            if missing:  # the key pickles the closure's cells: only for a signature not yet here
                key = cache._index_key(sig, run.targetctx.codegen())
                missing = key not in cache._cache_file._load_index()
        except (AttributeError, TypeError, OSError):
            missing = False
        if missing:
            with _compiling(cache._cache_file._index_path, key):
                if key not in cache._cache_file._load_index():  # not saved by another process meanwhile
                    save(sig)
        return original(sig)

    run.compile = compile
    return run
