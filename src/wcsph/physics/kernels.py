"""Smoothing kernels with support radius 2h, as Numba-jitable factories.

Each factory takes the working dtype and returns ``(w, gradfac)``:
``w(r, P)`` is W(r, h) and ``gradfac(r, P)`` is (dW/dr)/r, so that
``grad_i W_ij = gradfac(r_ij) * (x_i - x_j)``. Case-dependent factors come from the
parameter tuple ``P`` (``P.h_inv``, ``P.w_norm`` = sigma/h^d, ``P.g_norm`` = sigma/h^(d+2)),
so one compiled kernel serves every resolution; only dtype-typed constants are closed over
(a Python float literal would promote float32 arithmetic to float64).
"""
import math

import numpy as np
from numba.extending import register_jitable

#: support radius in units of h for every kernel here
SUPPORT = 2.0


def wendland_sigma(dim):
    """Wendland C2 normalisation, Wendland (1995); Dehnen & Aly (2012), support 2h."""
    return {2: 7.0 / (4.0 * math.pi), 3: 21.0 / (16.0 * math.pi)}[dim]


def cubic_sigma(dim):
    """Cubic B-spline normalisation, Monaghan & Lattanzio (1985), support 2h."""
    return {2: 10.0 / (7.0 * math.pi), 3: 1.0 / math.pi}[dim]


def make_wendland(dtype):
    """Wendland C2: W = sigma/h^d (1 - q/2)^4 (2q + 1), q = r/h < 2."""
    one, two, half, five = dtype(1), dtype(2), dtype(0.5), dtype(5)
    zero = dtype(0)

    @register_jitable
    def w(r, P):
        q = r * P.h_inv
        t = max(one - half * q, zero)
        t2 = t * t
        return P.w_norm * t2 * t2 * (two * q + one)

    @register_jitable
    def gradfac(r, P):
        q = r * P.h_inv
        t = max(one - half * q, zero)
        return -five * P.g_norm * t * t * t

    return w, gradfac


def make_cubic_spline(dtype):
    """Cubic B-spline of Monaghan & Lattanzio (1985), q = r/h < 2."""
    one, two, zero = dtype(1), dtype(2), dtype(0)
    c15, c075, c3, c225 = dtype(1.5), dtype(0.75), dtype(3), dtype(2.25)
    c025 = dtype(0.25)

    @register_jitable
    def w(r, P):
        q = r * P.h_inv
        if q < one:
            return P.w_norm * (one - c15 * q * q + c075 * q * q * q)
        t = max(two - q, zero)
        return P.w_norm * c025 * t * t * t

    @register_jitable
    def gradfac(r, P):
        q = r * P.h_inv
        if q < one:
            return P.g_norm * (-c3 + c225 * q)
        t = max(two - q, zero)
        return -P.g_norm * c075 * t * t / max(q, dtype(1e-12))

    return w, gradfac


KERNELS = {
    "wendland": (make_wendland, wendland_sigma),
    "cubic_spline": (make_cubic_spline, cubic_sigma),
}


def kernel_params(name, dim, h):
    """The case-dependent kernel factors: h_inv, w_norm and g_norm."""
    sigma = KERNELS[name][1](dim)
    return {"h_inv": 1.0 / h, "w_norm": sigma / h**dim, "g_norm": sigma / h ** (dim + 2)}


def make_kernel(name, dtype):
    """The jitable ``(w, gradfac)`` pair of kernel ``name`` for ``dtype``."""
    try:
        return KERNELS[name][0](np.dtype(dtype).type)
    except KeyError:
        raise ValueError(f"unknown kernel {name!r}; choose one of {sorted(KERNELS)}") from None


def kernel_numpy(name, dim, h):
    """Vectorised NumPy W(r) and (dW/dr)/r, the reference for tests and set-up sums."""
    sigma = KERNELS[name][1](dim)
    wn, gn = sigma / h**dim, sigma / h ** (dim + 2)

    def w(r):
        q = np.asarray(r, dtype=float) / h
        if name == "wendland":
            t = np.clip(1 - q / 2, 0, None)
            return wn * t**4 * (2 * q + 1)
        return wn * np.where(q < 1, 1 - 1.5 * q**2 + 0.75 * q**3, 0.25 * np.clip(2 - q, 0, None) ** 3)

    def gradfac(r):
        q = np.asarray(r, dtype=float) / h
        if name == "wendland":
            return -5 * gn * np.clip(1 - q / 2, 0, None) ** 3
        with np.errstate(divide="ignore", invalid="ignore"):
            far = -0.75 * np.clip(2 - q, 0, None) ** 2 / q
        return gn * np.where(q < 1, -3 + 2.25 * q, far)

    return w, gradfac


# ------------------------------------------------------------------------------ registry
from .registry import NONNEG, POS, SLOTS, Choice, Param, add  # noqa: E402

SLOTS["kernel"].params = (
    Param("smoothing_ratio", 2.0, "h / dp, when h is not given", check=POS),
    Param("h", 0.0, "smoothing length h; 0: smoothing_ratio dp", unit="m", check=NONNEG, spec=True),
    Param("searchRadius", 0.0, "neighbour search radius; 0: the support 2h", unit="m", check=NONNEG, spec=True),
)
add("kernel", Choice("wendland", "Wendland (1995); Dehnen & Aly (2012)", "C2, W = sigma/h^d (1 - q/2)^4 (2q + 1)"))
add("kernel", Choice("cubic_spline", "Monaghan & Lattanzio (1985)", "cubic B-spline"))


def smoothing_length(case):
    """h: ``model.h`` when given, else ``smoothing_ratio`` dp (the one place h is derived)."""
    m = case["model"]
    return m["h"] if m["h"] > 0 else m["smoothing_ratio"] * case["dp"]
