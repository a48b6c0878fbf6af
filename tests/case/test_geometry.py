"""Geometry of a case: wall particles of closed polygons (the classic model's boundary
particles, as the WCSPH-BI model's elements)."""
import numpy as np
import pytest

from wcsph.case import geometry
from wcsph.case.config import validate
from wcsph.errors import CaseError

BOX = [[0.2, 0.1], [0.2, 0.3], [0.6, 0.3], [0.6, 0.1]]  # clockwise: a body, the fluid outside


def _set(x):
    return {tuple(np.round(p, 9)) for p in x.T}


@pytest.mark.parametrize("layers", [1, 3])
def test_a_clockwise_box_polygon_samples_as_the_obstacle_box(layers):
    """A body's outline, clockwise, is sampled inside it, ``layers`` deep: for a rectangle on
    the fluid's lattice, exactly the particles of the same obstacle box."""
    got = geometry.polygon_particles(BOX, 0.05, layers, np.zeros(2))
    want = geometry.obstacle_particles({"min": [0.2, 0.1], "max": [0.6, 0.3]}, 0.05, layers)
    assert got.shape[1] > 0 and _set(got) == _set(want)


def test_a_counter_clockwise_polygon_is_walled_outside():
    """A container's outline, counter-clockwise (the fluid inside), is sampled outside it: every
    particle outside, within ``layers`` dp of the outline, on the fluid's lattice, and all the
    lattice points so placed."""
    pts = np.array(BOX[::-1], dtype=float)
    dp, layers = 0.05, 2
    x = geometry.polygon_particles(pts, dp, layers, np.array([0.0, 0.0]))
    inside = geometry._in_polygon(x, pts, 0.0)
    d = geometry._outline_distance(x, pts)
    assert x.shape[1] > 0 and not inside.any() and np.all(d < layers * dp)
    assert np.allclose(np.round(x / dp - 0.5), x / dp - 0.5, atol=1e-6)  # on the fluid's lattice
    ring = geometry.lattice([0.0, -0.1], [0.8, 0.5], dp)
    ring = ring[:, ~geometry._in_polygon(ring, pts, 0.0) & (geometry._outline_distance(ring, pts) < layers * dp)]
    assert _set(ring) == _set(x)


CLASSIC = {"dim": 2, "dp": 0.05, "time": {"end": 0.1}, "model": {"name": "classic"},
           "tank": {"min": [0.0, 0.0], "max": [1.0, 1.0], "open_top": True},
           "fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.5]}]}


def test_a_classic_case_walls_a_closed_polygon_with_particles():
    """The classic model's wall particles of a closed polygon: one body of its own (after the
    tank), and no fluid particle closer than dp to them."""
    case = validate(dict(CLASSIC, polygon=[{"points": BOX, "closed": True, "name": "block"}]))
    fluid, walls, _, _ = geometry.build(case)
    block = walls["x"][:, walls["body"] == 1]
    assert block.shape[1] > 0
    gap = np.sqrt(((fluid["x"][:, :, None] - block[:, None, :]) ** 2).sum(axis=0)).min()
    assert gap >= 0.05 - 1e-9


def test_an_open_polygon_with_wall_particles_is_one_line():
    case = validate(dict(CLASSIC, polygon=[{"points": [[0.2, 0.1], [0.6, 0.1]], "closed": False}]))
    with pytest.raises(CaseError, match=r"polygon\[0\]\.closed: an open polygon has no solid side"):
        geometry.build(case)
