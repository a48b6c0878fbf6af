"""Kernels: normalisation, gradient consistency, and the jitted forms against NumPy."""
from collections import namedtuple

import numpy as np
import pytest
from numba import njit

from wcsph.physics.kernels import SUPPORT, kernel_numpy, kernel_params, make_kernel

KP = namedtuple("KP", "h_inv w_norm g_norm")
CASES = [(name, dim) for name in ("wendland", "cubic_spline") for dim in (2, 3)]


@pytest.mark.parametrize("name,dim", CASES)
def test_normalised(name, dim):
    """The integral of W over its support is 1 (midpoint rule on a fine grid)."""
    h = 0.7
    n = 120 if dim == 2 else 60
    ax = (np.arange(n) + 0.5) / n * 2 * SUPPORT * h - SUPPORT * h
    r = np.sqrt(sum(m**2 for m in np.meshgrid(*([ax] * dim), indexing="ij")))
    w, _ = kernel_numpy(name, dim, h)
    integral = w(r).sum() * (2 * SUPPORT * h / n) ** dim
    assert integral == pytest.approx(1.0, abs=2e-3)


@pytest.mark.parametrize("name,dim", CASES)
def test_gradient_is_derivative(name, dim):
    """(dW/dr)/r times r equals the central difference of W, and vanishes at q = 2."""
    h = 0.5
    w, gradfac = kernel_numpy(name, dim, h)
    r = np.linspace(0.01, SUPPORT * h - 0.01, 200)
    eps = 1e-6
    fd = (w(r + eps) - w(r - eps)) / (2 * eps)
    np.testing.assert_allclose(gradfac(r) * r, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())
    assert w(SUPPORT * h) == pytest.approx(0.0, abs=1e-12)
    assert gradfac(SUPPORT * h) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("name,dim", CASES)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_jitted_matches_numpy(name, dim, dtype):
    h = 0.3
    jw, jg = make_kernel(name, dtype)
    P = KP(*(dtype(v) for v in kernel_params(name, dim, h).values()))

    @njit
    def evaluate(r, P):
        out = np.empty((2, r.size), dtype=r.dtype)
        for k in range(r.size):
            out[0, k] = jw(r[k], P)
            out[1, k] = jg(r[k], P)
        return out

    r = np.linspace(0.001, SUPPORT * h * 1.1, 101).astype(dtype)
    got = evaluate(r, P)
    assert got.dtype == dtype  # no silent promotion to float64
    w, g = kernel_numpy(name, dim, h)
    rtol = 1e-5 if dtype == np.float32 else 1e-12
    np.testing.assert_allclose(got[0], w(r.astype(float)), rtol=rtol, atol=rtol * w(0.0))
    np.testing.assert_allclose(got[1], g(r.astype(float)), rtol=rtol, atol=rtol * abs(g(1e-3)))
