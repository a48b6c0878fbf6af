"""The cell-list loop visits exactly the pairs a brute-force search finds."""
import os
import subprocess
import sys
from collections import namedtuple

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from numba.extending import register_jitable

from wcsph.backends.cpu import CpuBackend
from wcsph.backends.grid import Grid
from wcsph.backends.particles import ParticleSet

Set = namedtuple("Set", "x cell start count rsum")
NP = namedtuple("NP", "rc2")


def _make_loop(backend, dim):
    @register_jitable
    def init(i, I, P):
        return (0.0, 0.0)

    @register_jitable
    def pair(i, j, dx, dy, dz, r, I, J, P, acc):
        return (acc[0] + 1.0, acc[1] + r)

    @register_jitable
    def finish(i, I, P, acc):
        I.count[i] = acc[0]
        I.rsum[i] = acc[1]

    return backend.make_pass(dim, np.float64, init, pair, finish, pair2=pair, cache=False)


LOOPS = {}


def _cloud_case(dim, n, m, seed, rc, spread):
    rng = np.random.default_rng(seed)
    lo = np.zeros(dim)
    hi = np.full(dim, spread)
    be = CpuBackend()
    grid = Grid.covering(lo, hi, rc)
    sets = []
    for k in (n, m):
        x = rng.uniform(lo, hi, size=(k, dim)).T.copy()
        s = ParticleSet("p", dim, {"x": x})
        s["count"] = np.zeros(k)
        s["rsum"] = np.zeros(k)
        be.sort(s, grid)
        sets.append(s)
    if dim not in LOOPS:
        LOOPS[dim] = _make_loop(be, dim)
    I, J = (s.view(Set) for s in sets)
    LOOPS[dim](I, I, J, NP(rc * rc), grid.view())
    return sets


@settings(max_examples=25, deadline=None)
@given(dim=st.sampled_from([2, 3]), n=st.integers(1, 300), m=st.integers(0, 200),
       seed=st.integers(0, 2**31), rc=st.floats(0.05, 0.6), spread=st.floats(0.2, 2.0))
def test_cell_list_matches_brute_force(dim, n, m, seed, rc, spread):
    fluid, walls = _cloud_case(dim, n, m, seed, rc, spread)
    x = fluid["x"]
    allx = np.concatenate([x, walls["x"]], axis=1)
    d2 = ((x[:, :, None] - allx[:, None, :]) ** 2).sum(axis=0)
    inside = d2 < rc * rc
    np.testing.assert_array_equal(fluid["count"], inside.sum(axis=1))
    np.testing.assert_allclose(fluid["rsum"], np.where(inside, np.sqrt(d2), 0).sum(axis=1), rtol=1e-12)


def test_sort_orders_by_cell_and_keeps_particles():
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 1, size=(2, 500))
    s = ParticleSet("p", 2, {"x": x.copy(), "tag": np.arange(500.0)})
    grid = Grid.covering([0, 0], [1, 1], 0.1)
    assert CpuBackend().sort(s, grid) == 0
    assert np.all(np.diff(s["cell"]) >= 0)
    np.testing.assert_array_equal(np.sort(s["tag"]), np.arange(500.0))
    np.testing.assert_array_equal(s["x"], x[:, s["tag"].astype(int)])
    g = grid.view()
    for c in np.unique(s["cell"]):
        assert np.all(s["cell"][s["start"][c]:s["start"][c + 1]] == c)


def test_particles_leaving_the_domain_are_dropped():
    x = np.array([[0.5, 0.2, 5.0], [0.5, 0.3, 0.5]])
    s = ParticleSet("p", 2, {"x": x, "tag": np.arange(3.0)})
    assert CpuBackend().sort(s, Grid.covering([0, 0], [1, 1], 0.25)) == 1
    assert s.n == 2 and sorted(s["tag"]) == [0.0, 1.0]


NEIGHBOUR_LIST = os.path.join(os.path.dirname(__file__), "..", "..", "benchmarks", "neighbour_list.py")


@pytest.mark.validation
@pytest.mark.parametrize("mode", [["--precision", "float64"], ["--backend", "cuda", "--n", "300"], ["--ptx"]],
                         ids=["cpu", "cuda-simulator", "ptx"])
def test_the_neighbour_list_benchmark_gives_the_walks_results(mode):
    """``benchmarks/neighbour_list.py`` (README, Speed): the interaction pass over a neighbour
    list with a skin gives the cell walk's results (the script stops otherwise), on the CPU and
    in Numba's CUDA simulator, and its kernels compile to PTX for sm_90 (what the device check
    runs on a GPU)."""
    if mode[0] == "--ptx":
        from wcsph.validation.ptx import available

        if available() is not None:
            pytest.skip(available())
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1") if "cuda" in mode else dict(os.environ)
    args = ["--n", "2000", "--rounds", "1", *mode]
    r = subprocess.run([sys.executable, NEIGHBOUR_LIST, "dam_break_3d_bi", *args], capture_output=True, text=True,
                       env=env, timeout=900, cwd=os.path.dirname(NEIGHBOUR_LIST))
    assert r.returncode == 0, r.stderr[-3000:]
    assert ("PTX for sm_90" in r.stdout) if mode[0] == "--ptx" else ("list pass vs walk" in r.stdout), r.stdout
