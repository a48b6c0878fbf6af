"""The potential-flow reference of the oscillating-cylinder checks (``validation.potential``)
against the closed forms it must reproduce."""
import math

import numpy as np
import pytest

from wcsph.validation.potential import added_mass_2d


def _circle(r, n, clockwise=False):
    th = np.linspace(0.0, 2 * math.pi, n + 1)[:-1]
    p = r * np.c_[np.cos(th), np.sin(th)]
    return p[::-1] if clockwise else p


@pytest.mark.parametrize("clockwise", [False, True])
def test_added_mass_of_a_circle_in_a_concentric_circle(clockwise):
    """rho pi R^2 (b^2 + R^2) / (b^2 - R^2) (b = 2R: 5/3 of rho pi R^2), along x and y alike,
    whichever way the outlines run; the polygons' own area (n sides) taken out."""
    n = 96
    area = 0.5 * n * math.sin(2 * math.pi / n)  # of the unit n-gon, against pi
    mx, my = added_mass_2d(_circle(1.0, n, clockwise), _circle(2.0, 2 * n, not clockwise), panel_length=0.08)
    exact = 1000.0 * area * 5.0 / 3.0
    assert mx == pytest.approx(exact, rel=3e-3)
    assert my == pytest.approx(exact, rel=3e-3)


def test_added_mass_in_a_square_lies_between_its_two_circles():
    """A square tank of half side B confines less than its inscribed circle (b = B) and more
    than its circumscribed one (b = B sqrt 2): between the two closed forms (B = 4 R here,
    1.067 and 1.133 times rho pi R^2, where the panels give 1.112)."""
    n = 48
    area = 1000.0 * 0.5 * n * math.sin(2 * math.pi / n)
    mx, my = added_mass_2d(_circle(1.0, n), [(-4, -4), (4, -4), (4, 4), (-4, 4)], panel_length=0.15)
    inscribed, circumscribed = (16 + 1) / (16 - 1), (32 + 1) / (32 - 1)
    assert circumscribed * area < mx < inscribed * area
    assert my == pytest.approx(mx, rel=1e-9)  # the square's symmetry
