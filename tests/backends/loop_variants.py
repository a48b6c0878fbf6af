"""A helper process for ``test_cache.py``: one loop of ``cpu._loop`` (a prange over an array,
a closure as the passes are) made in a process of NUMBA_NUM_THREADS threads, run, and reported
as ``parallel hits misses ok``."""
import numpy as np
import numba

import wcsph  # noqa: F401 (installs the package's cache guards)
from wcsph.backends import cpu


def make(k):
    @cpu._loop(cache=True)
    def run(a):
        for i in numba.prange(a.size):
            a[i] = a[i] * k + i

    return run


if __name__ == "__main__":
    run = make(3.0)
    a = np.ones(64)
    run(a)
    ok = np.array_equal(a, 3.0 + np.arange(64))
    print(bool(run.targetoptions.get("parallel", False)), sum(run.stats.cache_hits.values()),
          sum(run.stats.cache_misses.values()), "ok" if ok else "WRONG")
