import os
import sys

import pytest

# One thread per test process (the suite runs a worker per core, up to four): the loops of
# the passes then compile without Numba's parallel form, about a third less compile time
# (backends/cpu._loop); subprocesses inherit it. The parallel loops are run by
# tests/backends/test_cache.py::test_a_process_of_two_threads_runs_parallel_loops_of_its_own.
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
if "numba" in sys.modules:  # imported before this file: one thread for this process too
    import numba

    numba.set_num_threads(min(numba.config.NUMBA_NUM_THREADS, int(os.environ["NUMBA_NUM_THREADS"])))

from wcsph.validation.references import DATA  # noqa: E402


@pytest.fixture
def validation_dir():
    """The published reference data, shipped inside the package (no skip on a plain clone)."""
    return DATA


@pytest.fixture
def martin_moyce_errors():
    """f(probes_csv, a) -> (T, relative error of the simulated surge front) at every Martin &
    Moyce (1952) point with T = t sqrt(2g/a) <= 3, from the run's ``surge_front`` column, the
    data taken the release delay later that fits them best (``surge_front_error``, as the
    validation check compares)."""
    import csv

    import numpy as np

    from wcsph.validation.references import surge_front_error

    def errors(probes_csv, a, g=9.81):
        with open(probes_csv) as f:
            rows = list(csv.DictReader(f))
        T = np.array([float(r["time"]) for r in rows]) * np.sqrt(2 * g / a)
        Z = np.array([float(r["surge_front"]) for r in rows]) / a
        assert Z[0] == pytest.approx(1.0, abs=0.01)
        delay, ref_T, err = surge_front_error(T, Z, "martin_moyce_1952")
        assert len(ref_T) >= 5
        return ref_T, err

    return errors


@pytest.fixture
def box_stl(tmp_path):
    """f(name, lo, hi) -> the path of a closed STL box [lo, hi] (12 triangles) in tmp_path."""
    import meshio
    import numpy as np

    def write(name, lo, hi):
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
        tri = np.array([t for q in quads for t in ([q[0], q[1], q[2]], [q[0], q[2], q[3]])])
        path = tmp_path / name
        meshio.write(path, meshio.Mesh(corners, [("triangle", tri)]))
        return str(path)

    return write
