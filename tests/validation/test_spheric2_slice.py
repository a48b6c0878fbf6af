"""SPHERIC 2's slice (``validation.spheric2.slice_case``): the case the accuracy study's 2D
and periodic 3D runs use, and the means it reads."""
import numpy as np
import pytest

from wcsph.case import geometry
from wcsph.case.config import validate
from wcsph.validation import spheric2

MODEL = {"name": "bi", "BCType": "BIConsistent_numeric"}


@pytest.mark.parametrize("width", [None, 0.3])
def test_the_slice_puts_the_box_and_its_sensors_where_the_experiment_has_them(width):
    case = validate(spheric2.slice_case(MODEL, 0.025, width))
    fluid, walls, _, _ = geometry.build(case)
    x = fluid["x"]
    assert x[0].min() > 1.992 and x[0].max() < 3.22 and x[-1].max() < 0.55
    face = walls["x"][:, (walls["body"] == 1) & (walls["n"][0] < -0.5)]  # the face the water hits (n into the box)
    assert np.allclose(face[0], 0.8245) and face[-1].max() < 0.161
    sensors = {p["name"]: p["position"] for p in case["probes"]}
    assert sensors["P3"][0] == sensors["P3s"][0] == 0.8245 and sensors["P3"][-1] == 0.101
    if width is not None:
        assert case["domain"]["periodic"] == [False, True, False] and sensors["P1"][1] == width / 2
        assert walls["x"][1].min() >= 0.0 and walls["x"][1].max() <= width  # no faces across y


def test_face_means_average_the_quasi_steady_phase(tmp_path):
    t = np.arange(0.0, 2.0, 0.1)
    path = tmp_path / "probes.csv"
    rows = ["time,P1,P1s,H2"] + [f"{v:.1f},{1000 * v:.1f},{2000 * v:.1f},{v}" for v in t]
    path.write_text("\n".join(rows) + "\n")
    m = spheric2.face_means(path)
    assert set(m) == {"P1", "P1s"}
    assert m["P1"] == pytest.approx(1000.0) and m["P1s"] == pytest.approx(2000.0)
