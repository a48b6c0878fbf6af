"""Lobovsky et al.'s (2014) level records (their Fig. 16 as TNL-SPH ships it), which the
``lobovsky`` check shows beside the wall pressures: read as the gauges' positions say."""
import numpy as np

from wcsph.validation import references as ref
from wcsph.validation.references import DATA


def test_the_gauges_wet_in_the_order_of_their_distance_from_the_gate():
    wet = []
    for k in (1, 2, 3, 4):
        T, h = ref.lobovsky_level(k)
        assert np.all(np.diff(T) > 0) and T[0] == 0 and T[-1] > 11
        assert np.all((h >= 0) & (h <= 1.0))
        wet.append(T[np.argmax(h > 0.01)])
    T1, h1 = ref.lobovsky_level(1)
    assert h1[0] == 1.0  # H1 stands in the reservoir, 0.3 m from its back wall
    assert wet[0] == 0 and 0.9 < wet[1] < 1.1 and 1.6 < wet[2] < 1.75 and 2.1 < wet[3] < 2.2


def test_the_two_series_of_a_gauge_agree_after_the_impact():
    """The loader's mean of the two series at H2-H4: they agree within 0.012 h/H over the
    check's window, 3 <= T <= 5 (the spread of the experiment's repetitions)."""
    for k in (2, 3, 4):
        d = np.loadtxt(DATA / f"lobovsky_2014_level_H{k}.dat", comments="#")
        assert d.shape[1] == 3
        w = (d[:, 0] >= 3) & (d[:, 0] <= 5)
        assert abs(d[w, 1].mean() - d[w, 2].mean()) < 0.012, k
        T, h = ref.lobovsky_level(k)
        assert np.allclose(h, d[:, 1:].mean(axis=1))
