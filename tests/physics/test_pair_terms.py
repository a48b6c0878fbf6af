"""Pair terms called directly, on two particles: the jitable functions of ``physics/`` are
plain Python functions too, so each can be checked against its formula without a loop, a
grid or a case run. (The end-to-end tests check the same terms inside the passes.)"""
from collections import namedtuple

import numpy as np
import pytest

from wcsph import Simulation
from wcsph.case.config import load
from wcsph.physics.kernels import kernel_numpy
from wcsph.physics import Ctx
from wcsph.physics.density import make_summation
from wcsph.physics.diffusion import make_molteni
from wcsph.physics.pressure import make_bi_pressure, make_monaghan_pi, make_symmetric_pressure
from wcsph.physics.viscosity import make_artificial_viscosity, make_mgvt, make_mvt

Pair = namedtuple("Pair", "x v rho p pr vol m c")
ZERO = (0.0,) * 9
H = 0.02


@pytest.fixture(scope="module")
def P():
    """The parameters of a 2D WCSPH-BI case in float64, h = 0.02 m, with viscosity, diffusion
    and Monaghan's Pi set (the values the terms read)."""
    case = load("dam_break_2d_bi", [("dp", 0.01), ("precision", "float64"), ("model.ViscousTerm", "PhysicalViscosity_MVT"),
                                    ("model.dynamicViscosity", 1e-3), ("time.max_steps", 1)])
    return Simulation(case).P._replace(av_alpha_h=0.01 * H, av_beta_h2=0.0)


@pytest.fixture(scope="module")
def ctx():
    return Ctx.create(np.float64, 2, "wendland")


def _pair(rng):
    """Two particles 0.8 h to 1.6 h apart, random velocities, densities near 1000, pressures."""
    x0 = np.zeros(2)
    d = rng.uniform(0.8, 1.6) * H
    a = rng.uniform(0, 2 * np.pi)
    x = np.stack([x0, x0 + d * np.array([np.cos(a), np.sin(a)])], axis=1)
    v = rng.normal(size=(2, 2))
    rho = rng.uniform(990, 1010, size=2)
    p = rng.uniform(0, 3000, size=2)
    m = np.full(2, 0.1)
    return Pair(np.vstack([x, np.zeros((1, 2))]), np.vstack([v, np.zeros((1, 2))]), rho, p, p / rho ** 2, m / rho, m,
                np.full(2, 17.0))


def _call(term, pair, i, j, P):
    d = pair.x[:, i] - pair.x[:, j]
    return term(i, j, d[0], d[1], d[2], float(np.linalg.norm(d)), pair, pair, P, ZERO)


def _momentum(acc, pair, i):
    """m_i a_i from the accumulator: the force slot is rho_i a_i (times V_i), the acceleration slot a_i."""
    return pair.vol[i] * np.array(acc[2:5]) + pair.m[i] * np.array(acc[5:8])


@pytest.mark.parametrize("make", [make_bi_pressure, make_symmetric_pressure, make_mvt, make_mgvt,
                                  make_artificial_viscosity, make_monaghan_pi])
def test_a_fluid_pair_exchanges_momentum_equal_and_opposite(make, P, ctx):
    term = make(ctx)
    rng = np.random.default_rng(7)
    for _ in range(20):
        pair = _pair(rng)
        total = _momentum(_call(term, pair, 0, 1, P), pair, 0) + _momentum(_call(term, pair, 1, 0, P), pair, 1)
        scale = np.abs(_momentum(_call(term, pair, 0, 1, P), pair, 0)).max() + 1e-300
        assert np.abs(total).max() <= 1e-12 * scale


def test_bi_pressure_is_its_formula(P, ctx):
    """f_i = -(p_i + p_j) grad_i W_ij V_j, grad_i W = (dW/dr / r) x_ij (Wendland C2, 2D)."""
    _, grad = kernel_numpy("wendland", 2, H)
    pair = _pair(np.random.default_rng(1))
    d = pair.x[:2, 0] - pair.x[:2, 1]
    r = np.linalg.norm(d)
    expected = -(pair.p[0] + pair.p[1]) * grad(r) * pair.vol[1] * d
    got = np.array(_call(make_bi_pressure(ctx), pair, 0, 1, P)[2:4])
    assert got == pytest.approx(expected, rel=1e-12)


def test_summation_density_is_m_w(P, ctx):
    w, _ = kernel_numpy("wendland", 2, H)
    pair = _pair(np.random.default_rng(2))
    r = np.linalg.norm(pair.x[:, 0] - pair.x[:, 1])
    d = pair.x[:, 0] - pair.x[:, 1]
    assert make_summation(ctx)(0, 1, d[0], d[1], d[2], r, pair, pair, P, 0.0) == pytest.approx(pair.m[1] * w(r), rel=1e-12)


def test_viscous_terms_vanish_without_relative_motion(P, ctx):
    pair = _pair(np.random.default_rng(3))
    pair = pair._replace(v=np.repeat(pair.v[:, :1], 2, axis=1))  # a rigid translation
    for make in (make_mvt, make_mgvt, make_artificial_viscosity, make_monaghan_pi):
        assert np.abs(_call(make(ctx), pair, 0, 1, P)[2:8]).max() == 0.0, make.__name__


def test_artificial_viscosity_acts_on_approaching_pairs_only(P, ctx):
    pair = _pair(np.random.default_rng(4))
    d = pair.x[:, 1] - pair.x[:, 0]
    for sign, acting in ((+1.0, True), (-1.0, False)):  # particle 0 moving toward 1, then away
        v = np.zeros((3, 2))
        v[:, 0] = sign * d / np.linalg.norm(d)
        acc = _call(make_artificial_viscosity(ctx), pair._replace(v=v), 0, 1, P)
        assert (np.abs(acc[2:5]).max() > 0) == acting


def test_molteni_diffusion_moves_density_down_its_gradient(P, ctx):
    """delta h c0 psi_ij . grad W V_j, psi = 2 (rho_j - rho_i) x_ji / r^2: particle i gains
    density from a denser neighbour and loses it to a lighter one."""
    pair = _pair(np.random.default_rng(5))
    term = make_molteni(ctx)
    for rho, sign in (((1000.0, 1010.0), 1), ((1010.0, 1000.0), -1)):
        acc = _call(term, pair._replace(rho=np.array(rho)), 0, 1, P)
        assert np.sign(acc[1]) == sign


@pytest.mark.parametrize("a_wall", [(0.0, 0.0), (3.0, -2.0)])
def test_wall_pressure_is_exact_in_a_fluid_accelerating_with_the_wall(a_wall, P, ctx):
    """A fluid at rest relative to a wall of acceleration a_b has p = rho (g - a_b) . (x - x_s):
    the wall's interpolated pressure (Adami et al. 2012, eq. 27) is then exact, whatever the
    weights, because every neighbour carries its own p to the wall along that gradient. The
    same field read without a_b is off by rho a_b . (x_b - x_j) per neighbour."""
    from wcsph.physics.renormalization import make_boundary_interpolation, make_boundary_store

    Wall = namedtuple("Wall", "x a")
    rng = np.random.default_rng(6)
    g = np.array([P.gx, P.gy])
    rho = 1000.0
    xb = np.array([0.0, 0.0])
    xs = rng.uniform(-0.1, 0.1, 2)
    xf = xb[:, None] + rng.uniform(-1.5, 1.5, (2, 6)) * H
    p = rho * ((g - a_wall) @ (xf - xs[:, None]))
    fluid = Pair(np.vstack([xf, np.zeros((1, 6))]), np.zeros((3, 6)), np.full(6, rho), p, p / rho**2,
                 np.full(6, 1e-4), np.full(6, 0.1), np.full(6, 17.0))
    wall = Wall(xb[:, None], np.array(a_wall, dtype=float)[:, None])
    term = make_boundary_interpolation(ctx)
    acc = make_boundary_store(ctx)[0](0, wall, P)  # the pass's start: g - a_b carried along
    for j in range(6):
        d = xb - xf[:, j]
        acc = term(0, j, d[0], d[1], 0.0, float(np.linalg.norm(d)), wall, fluid, P, acc)
    assert acc[2] > 0
    assert acc[0] / acc[2] == pytest.approx(rho * (g - a_wall) @ (xb - xs), rel=1e-12, abs=1e-9)



def test_wall_corrections_leave_a_particle_beside_a_convex_corner(ctx):
    """The elastic bounce and NBVC-PST of one boundary element, called directly: the element
    is a square's front face (normal -x, out of the fluid that lies at x > 0), moving at
    U = 1 m/s into water at rest. A particle in front of it (or one that got behind it, over
    it) is bounced to 2U and pushed back to its radius; one behind its plane but beside it,
    over the square's top face round the corner, is left alone (it was bounced to 2U before,
    which made the water over SPHERIC 6's square run ahead of it)."""
    from wcsph.physics.wall_corrections import make_init, make_wall_corrections

    dp = 0.01
    Elem = namedtuple("Elem", "x n v elementSize")
    Fluid = namedtuple("Fluid", "x v m rho")
    Par = namedtuple("Par", "back r_box2 dt min_dist elastic")
    J = Elem(np.zeros((3, 1)), np.array([[-1.0], [0.0], [0.0]]), np.array([[1.0], [0.0], [0.0]]), np.array([dp]))
    P = Par(0.55 * dp, (1.5 * dp) ** 2, 1e-4, 0.5 * dp, 1.0)
    term = make_wall_corrections(ctx, True, False, True)
    init = make_init(ctx)

    def corrected(x, y):
        I = Fluid(np.array([[x], [y], [0.0]]), np.zeros((3, 1)), np.array([1000 * dp * dp]), np.array([1000.0]))
        acc0 = init(0, I, P)
        acc = term(0, 0, x, y, 0.0, float(np.hypot(x, y)), I, J, P, acc0)
        return acc[0], acc[3]  # v_x after, x shift

    radius = 0.5 * dp
    v, s = corrected(0.3 * dp, 0.1 * dp)  # in front, closer than its radius, the wall approaching
    assert v == pytest.approx(2.0) and s == pytest.approx(radius - 0.3 * dp)
    v, s = corrected(-0.3 * dp, 0.2 * dp)  # behind the plane over the element: in the wall
    assert v == pytest.approx(2.0) and s == pytest.approx(radius + 0.3 * dp)
    v, s = corrected(-0.3 * dp, 1.2 * dp)  # behind the plane beside it: over the next face
    assert v == 0.0 and s == 0.0


def test_werner_wengle_wall_law_gives_the_power_laws_shear(P, ctx):
    """A particle y above a floor element sliding along it at u_t (and moving off it at u_n):
    the wall law's term is the no-slip term below y+ = 11.81; above it the tangential force is
    the no-slip one times rho u_tau^2 y / (mu u_t), u_tau solved here from the power law
    u_t / u_tau = 8.3 (y u_tau / nu)^(1/7) (Werner & Wengle 1991), and the normal force is
    unchanged."""
    from wcsph.physics.viscosity import make_boundary_viscosity

    Elem = namedtuple("Elem", "x n v elementSize")
    Fluid = namedtuple("Fluid", "x v rho")
    J = Elem(np.zeros((3, 1)), np.array([[0.0], [-1.0], [0.0]]), np.zeros((3, 1)), np.array([0.01]))
    nu = 1e-6
    Pw = P._replace(wall_nu=nu, wall_visc=2.0 * 1e-3)
    laminar = make_boundary_viscosity(ctx, False)
    law = make_boundary_viscosity(ctx, False, "werner-wengle")

    def forces(term, y, ut, un):
        I = Fluid(np.array([[0.0], [y], [0.0]]), np.array([[ut], [un], [0.0]]), np.array([1000.0]))
        acc = term(0, 0, 0.0, y, 0.0, y, I, J, Pw, ZERO)
        return np.array(acc[2:4])

    y = 0.005
    slow = 100 * nu / y  # y+ < 11.81 at this slip
    assert np.array_equal(forces(law, y, slow, 0.3 * slow), forces(laminar, y, slow, 0.3 * slow))
    for ut in (0.5, 2.0, 5.0):
        lo, hi = 1e-6, ut  # bisection: ut / u - 8.3 (y u / nu)^(1/7) falls with u
        for _ in range(200):
            u_tau = (lo * hi) ** 0.5
            lo, hi = (u_tau, hi) if ut / u_tau > 8.3 * (y * u_tau / nu) ** (1 / 7) else (lo, u_tau)
        assert y * u_tau / nu > 11.81
        ratio = u_tau ** 2 * y / (nu * ut)
        f_law, f_lam = forces(law, y, ut, 0.1), forces(laminar, y, ut, 0.1)
        f_lam_t, f_lam_n = forces(laminar, y, ut, 0.0)[0], forces(laminar, y, 0.0, 0.1)[1]
        assert f_law[0] == pytest.approx(ratio * f_lam_t, rel=1e-9) and ratio > 5
        assert f_law[1] == pytest.approx(f_lam_n, rel=1e-12) and f_law[1] == pytest.approx(f_lam[1], rel=1e-12)
        assert f_law[0] * ut < 0  # against the slip


def test_wall_law_read_at_a_layer_thickness_gives_that_layers_shear(P, ctx):
    """With ``wall_layer`` = delta the law is read at max(y, delta): a particle nearer the wall
    than delta, sliding at u_t, takes the tangential force of the layer delta thick with outer
    speed u_t (the laminar one times rho u_tau^2 y / (mu u_t), u_tau from the power law at
    delta: one shear rho u_tau^2 wherever it is inside the layer), less than read at its own y;
    beyond delta it is read at its own y (the layer 0 case); and a slip too slow for the law is
    the no-slip term."""
    from wcsph.physics.viscosity import make_boundary_viscosity

    Elem = namedtuple("Elem", "x n v elementSize")
    Fluid = namedtuple("Fluid", "x v rho")
    J = Elem(np.zeros((3, 1)), np.array([[0.0], [-1.0], [0.0]]), np.zeros((3, 1)), np.array([0.01]))
    nu, delta, ut = 1e-6, 0.02, 2.0
    laminar = make_boundary_viscosity(ctx, False)
    law = make_boundary_viscosity(ctx, False, "werner-wengle")

    def tangential(term, y, layer, u=ut):
        Pw = P._replace(wall_nu=nu, wall_visc=2.0 * 1e-3, wall_layer=layer)
        I = Fluid(np.array([[0.0], [y], [0.0]]), np.array([[u], [0.0], [0.0]]), np.array([1000.0]))
        return term(0, 0, 0.0, y, 0.0, y, I, J, Pw, ZERO)[2]

    lo, hi = 1e-6, ut
    for _ in range(200):
        u_tau = (lo * hi) ** 0.5
        lo, hi = (u_tau, hi) if ut / u_tau > 8.3 * (delta * u_tau / nu) ** (1 / 7) else (lo, u_tau)
    for y in (0.002, 0.005, 0.0125):  # inside the layer: the layer's shear, not the particle's own
        ratio = u_tau ** 2 * y / (nu * ut)
        assert tangential(law, y, delta) == pytest.approx(ratio * tangential(laminar, y, delta), rel=1e-9)
        assert abs(tangential(law, y, delta)) < abs(tangential(law, y, 0.0))  # read at y: a thinner layer's
    y = 0.03  # beyond the layer: read at its own distance, as without one
    assert tangential(law, y, delta) == tangential(law, y, 0.0)
    slow = 100 * nu / delta  # y_l+ below 11.81: the laminar term
    assert tangential(law, 0.005, delta, slow) == tangential(laminar, 0.005, delta, slow)
