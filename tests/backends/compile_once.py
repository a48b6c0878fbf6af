"""Run by ``test_cache.py``, two at once over one empty cache: say it is ready (a file beside
the one named on the command line), wait for that file, then call a cached parallel loop (``saved_first``), and print how many times
this process compiled it and whether it computed the right numbers."""
import os
import sys
import time

import numpy as np
from numba import njit, prange

import wcsph  # noqa: F401  (installs the cache guards)
from wcsph.backends import numba_cache

compiled = [0]
twin_compile = numba_cache._TwinDispatcher.compile


def counted(self, sig):
    compiled[0] += 1
    return twin_compile(self, sig)


numba_cache._TwinDispatcher.compile = counted


@numba_cache.saved_first
@njit(parallel=True, fastmath=True, cache=True)
def spread(a, out):
    for i in prange(a.size):
        out[i] = a[i] * 0.1 + a[i] / 3.0 + np.sqrt(a[i])


open(sys.argv[1] + f".ready{os.getpid()}", "w").close()
while not os.path.exists(sys.argv[1]):
    time.sleep(0.005)
a = np.linspace(0.0, 1.0, 1000)
out = np.empty_like(a)
spread(a, out)
print(compiled[0], "ok" if np.allclose(out, a * 0.1 + a / 3.0 + np.sqrt(a)) else "WRONG")
