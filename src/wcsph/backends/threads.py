"""How the CPU loops share the cores: chosen here, at import, before Numba starts its
threads, so that no user has to set an environment variable.

Measured on a 2-core host (``benchmarks/loaded.py``), a 5,000-particle dam-break step:

================================  ==========  ===================================
threading layer                    idle        one CPU-bound process beside it
================================  ==========  ===================================
OpenMP (Numba's default), spin     0.91 ms     3.15 ms mean (steps of 1 to 30 ms)
OpenMP, ``OMP_WAIT_POLICY=passive``  1.64 ms     1.79 ms
workqueue                          2.01 ms     2.44 ms
one thread                         1.61 ms     1.58 ms
TBB (work stealing)                0.92 ms     1.62 ms
================================  ==========  ===================================

OpenMP's spinning threads wait for a partner the scheduler has parked; passive waiting
costs 50 us per parallel region (a step has about ten) on an idle machine. TBB keeps the
idle speed and degrades like one thread under load, so it is the layer we use. The ``tbb``
wheel installs ``libtbb.so.12`` inside the environment, where Numba's loader does not look:
we load it first by its full path. Without it (a platform with no wheel) the OpenMP layer
waits passively. ``NUMBA_THREADING_LAYER`` set by the user wins over both.
"""
import ctypes
import os
import sys
from importlib import metadata

#: the layer chosen at import ("tbb", "omp", or the user's NUMBA_THREADING_LAYER)
LAYER = None


def _tbb_library():
    try:
        files = metadata.files("tbb") or []
    except metadata.PackageNotFoundError:
        return None
    names = {"linux": "libtbb.so.12", "darwin": "libtbb.12.dylib", "win32": "tbb12.dll"}
    want = names.get(sys.platform)
    for f in files:
        if f.name == want:
            path = f.locate()
            if os.path.exists(path):
                return str(path)
    return None


def configure():
    """Choose the threading layer once, before the first parallel loop runs."""
    global LAYER
    if LAYER is not None:
        return LAYER
    import numba

    user = os.environ.get("NUMBA_THREADING_LAYER")
    if user:
        LAYER = user
        return LAYER
    lib = _tbb_library()
    if lib is not None:
        try:
            ctypes.CDLL(lib, mode=ctypes.RTLD_GLOBAL)
            numba.config.THREADING_LAYER = "tbb"
            LAYER = "tbb"
            return LAYER
        except OSError:
            pass
    os.environ.setdefault("OMP_WAIT_POLICY", "passive")  # read when libgomp loads
    numba.config.THREADING_LAYER = "omp"
    LAYER = "omp"
    return LAYER
