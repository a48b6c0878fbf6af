import pytest

from wcsph.validation.references import DATA


@pytest.fixture
def validation_dir():
    """The published reference data, shipped inside the package (no skip on a plain clone)."""
    return DATA


@pytest.fixture
def martin_moyce_errors(validation_dir):
    """f(probes_csv, a) -> (T, relative error of the simulated surge front) at every Martin &
    Moyce (1952) point with T = t sqrt(2g/a) <= 2.5, from the run's ``surge_front`` column."""
    import csv

    import numpy as np

    with open(validation_dir / "martin_moyce_1952_surge_front.csv") as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    ref = np.array([[float(r["T"]), float(r["Z"])] for r in rows])
    ref = ref[ref[:, 0] <= 2.5]
    assert len(ref) >= 5

    def errors(probes_csv, a, g=9.81):
        with open(probes_csv) as f:
            rows = list(csv.DictReader(f))
        T = np.array([float(r["time"]) for r in rows]) * np.sqrt(2 * g / a)
        Z = np.array([float(r["surge_front"]) for r in rows]) / a
        assert Z[0] == pytest.approx(1.0, abs=0.01)
        return ref[:, 0], np.interp(ref[:, 0], T, Z) / ref[:, 1] - 1

    return errors
