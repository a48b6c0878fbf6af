"""The CIEM comparison (``validation.ciem_figures``) on the record itself: a run that equals
the record, delayed, has the record's heights and that delay at each gauge."""
import numpy as np
import pytest

from wcsph.validation import CIEM_WAVES, ciem_figures
from wcsph.validation import references as ref


@pytest.mark.parametrize("delay", [0.0, 0.03, -0.02])
def test_a_run_equal_to_the_record_has_its_heights_and_its_delay(delay):
    t_ref, piston, eta = ref.ciem_wavemaker()
    assert t_ref[0] == 0.0 and t_ref[-1] == pytest.approx(7.0) and np.ptp(piston) == pytest.approx(0.052, abs=1e-3)
    t = np.arange(0.0, 7.0, 0.005)
    levels = {name: 0.31 + np.interp(t - delay, t_ref, eta[name]) for name in CIEM_WAVES}
    waves, lags, _ = ciem_figures(t, levels)
    assert len(waves) == sum(len(s) for s in CIEM_WAVES.values())
    for name, a, h_run, h_ref, e in waves:
        assert 0.06 < h_ref < 0.08  # the record's waves: about 7 cm
        assert abs(e) < 0.03  # a delayed copy's crest and trough, sampled at the record's times
    assert lags == {name: pytest.approx(delay, abs=0.0015) for name in CIEM_WAVES}
