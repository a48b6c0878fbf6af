"""Regular waves at gauges: heights and periods by zero up-crossings, and the reflection
coefficient from two gauges (Goda & Suzuki 1976)."""
import math

import numpy as np


def zero_crossing(t, eta):
    """(mean height, mean period) of the waves of the record eta(t) (its linear trend removed):
    between consecutive zero up-crossings (interpolated), the crest minus the trough, and the
    time."""
    e = eta - np.polyval(np.polyfit(t, eta, 1), t)
    up = np.flatnonzero((e[:-1] < 0) & (e[1:] >= 0))
    tc = t[up] - e[up] * (t[up + 1] - t[up]) / (e[up + 1] - e[up])
    heights = [e[a:b + 1].max() - e[a:b + 1].min() for a, b in zip(up[:-1], up[1:])]
    if len(heights) < 2:
        return float("nan"), float("nan")
    return float(np.mean(heights)), float(np.mean(np.diff(tc)))


def goda_suzuki(t, eta1, eta2, period, spacing, k):
    """(incident amplitude, reflected amplitude) at gauge 1 from two gauges ``spacing`` apart
    (gauge 2 further from the wavemaker), their records' Fourier components at 1/period over a
    whole number of periods: eta = a_I e^{i(-kx + wt)} + a_R e^{i(kx + wt)}."""
    n = int((t[-1] - t[0]) / period)
    keep = t >= t[-1] - n * period
    tt = t[keep]
    w = 2 * math.pi / period

    def component(e):
        e = e[keep] - e[keep].mean()
        return 2 * np.trapezoid(e * np.exp(-1j * w * tt), tt) / (tt[-1] - tt[0])

    c1, c2 = component(eta1), component(eta2)
    kd = k * spacing
    a_i = (c1 * np.exp(1j * kd) - c2) / (2j * math.sin(kd))   # c2 = a_I e^{-ikd} + a_R e^{ikd}
    a_r = (c2 - c1 * np.exp(-1j * kd)) / (2j * math.sin(kd))
    return float(abs(a_i)), float(abs(a_r))
