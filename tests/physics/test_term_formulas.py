"""Every pair term against its formula, called directly on two particles (or on a small cloud
where the property is a sum's): the jitable functions of ``physics/`` are plain Python
functions, so each is checked without a loop, a grid or a case run. Formulas in NumPy are
written from the papers the terms cite (their docstrings), not from the code."""
from collections import namedtuple

import numpy as np
import pytest

from wcsph import Simulation
from wcsph.case.config import load
from wcsph.physics import Ctx
from wcsph.physics.collision import make_dpc
from wcsph.physics.correction import make_cspm_matrix
from wcsph.physics.density import make_akinci_density, make_boundary_divergence, make_divergence
from wcsph.physics.diffusion import make_fourtakas, make_molteni
from wcsph.physics.eos import make_cole, make_linearized_cole, make_tait
from wcsph.physics.kernels import kernel_numpy
from wcsph.physics.pressure import (make_akinci_pressure, make_bi_boundary_pressure, make_corrected_pressure,
                                    make_bi_pressure)
from wcsph.physics.viscosity import make_artificial_viscosity, make_boundary_viscosity, make_mgvt, make_mvt
from wcsph.physics.xsph import make_xsph, make_xsph_position

H = 0.02
ZERO = (0.0,) * 9
Set = namedtuple("Set", "x v rho p pr vol m c psi n elementSize L")
W, GRAD = kernel_numpy("wendland", 2, H)  # W(r) and (dW/dr)/r


@pytest.fixture(scope="module")
def P():
    """2D WCSPH-BI parameters in float64 (h = 0.02 m, c0 from the case), with every
    coefficient a term reads set to a value of its own."""
    case = load("dam_break_2d_bi", [("dp", 0.01), ("precision", "float64"), ("time.max_steps", 1)])
    return Simulation(case).P._replace(visc=0.7, wall_visc=0.3, xsph_dt=50.0, wall_xsph_dt=20.0, xsph_epsilon=0.3,
                                       eps_h2=0.01 * H * H)


@pytest.fixture(scope="module")
def ctx():
    return Ctx.create(np.float64, 2, "wendland")


def _set(rng, n=2, spread=1.6):
    """n particles within ``spread`` h of the origin, random velocities, densities, pressures;
    as a wall set: random unit normals, element sizes and pseudo-masses."""
    x = np.zeros((3, n))
    x[:2] = rng.uniform(-spread, spread, (2, n)) * H / np.sqrt(2)
    a = rng.uniform(0, 2 * np.pi, n)
    n_ = np.zeros((3, n))
    n_[0], n_[1] = np.cos(a), np.sin(a)
    rho = rng.uniform(990, 1010, n)
    p = rng.uniform(0, 3000, n)
    m = rng.uniform(0.09, 0.11, n)
    v = np.zeros((3, n))
    v[:2] = rng.normal(size=(2, n))
    L = np.tile(np.array([1.0, 0, 0, 1.0])[:, None], n)  # the CSPM matrix L_i = I, row by row
    return Set(x, v, rho, p, p / rho ** 2, m / rho, m, np.full(n, 17.0), rng.uniform(0.08, 0.12, n), n_,
               rng.uniform(0.005, 0.01, n), L)


def _call(term, I, J, i, j, P, acc=ZERO):
    d = I.x[:, i] - J.x[:, j]
    return np.array(term(i, j, d[0], d[1], d[2], float(np.linalg.norm(d)), I, J, P, acc))


def _geometry(I, J, i=0, j=1):
    d = (I.x[:, i] - J.x[:, j])[:2]
    r = np.linalg.norm(d)
    return d, r, GRAD(r) * d  # x_ij, r, grad_i W_ij


@pytest.fixture
def pair():
    return _set(np.random.default_rng(11))


# ------------------------------------------------------------------------------ density
def test_divergence_is_its_formula(pair, P, ctx):
    """<div v>_i += (v_j - v_i) . grad_i W_ij V_j (slot 0)."""
    d, r, g = _geometry(pair, pair)
    expected = (pair.v[:2, 1] - pair.v[:2, 0]) @ g * pair.vol[1]
    assert _call(make_divergence(ctx), pair, pair, 0, 1, P)[0] == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("conservative", [True, False])
def test_boundary_divergence_is_its_formula(conservative, P, ctx):
    """c (v_b - v_i) . n_b W_ib S_b, c = 2 (conservative) or 1."""
    rng = np.random.default_rng(12)
    I, B = _set(rng), _set(rng)
    d, r, _ = _geometry(I, B, 0, 1)
    expected = (2 if conservative else 1) * (B.v[:2, 1] - I.v[:2, 0]) @ B.n[:2, 1] * W(r) * B.elementSize[1]
    got = _call(make_boundary_divergence(ctx, conservative), I, B, 0, 1, P)[0]
    assert got == pytest.approx(expected, rel=1e-12)


def test_divergence_of_a_linear_field_on_a_full_lattice(P, ctx):
    """On a square lattice with a full kernel support, sum_j (v_j - v_i) . grad W V_j of
    v = A x is trace(A) to the lattice's quadrature error (the kernel normalization: well
    under 1 % at h = 2 dp)."""
    dp = H / 2
    g = np.arange(-5, 6) * dp
    X, Y = np.meshgrid(g, g)
    x = np.zeros((3, X.size))
    x[0], x[1] = X.ravel(), Y.ravel()
    A = np.array([[0.3, -1.1], [0.7, 0.5]])
    v = np.zeros_like(x)
    v[:2] = A @ x[:2]
    n = x.shape[1]
    rho = np.full(n, 1000.0)
    cloud = Set(x, v, rho, np.zeros(n), np.zeros(n), np.full(n, dp * dp), rho * dp * dp, np.zeros(n), np.zeros(n),
                np.zeros((3, n)), np.zeros(n), np.zeros((4, n)))
    i = int(np.argmin(np.linalg.norm(x, axis=0)))
    term, acc = make_divergence(ctx), ZERO
    for j in range(n):
        r = np.linalg.norm(x[:, i] - x[:, j])
        if j != i and r < 2 * H:
            acc = _call(term, cloud, cloud, i, j, P, acc)
    assert acc[0] == pytest.approx(np.trace(A), rel=5e-3)


def test_akinci_density_is_psi_w(pair, P, ctx):
    _, r, _ = _geometry(pair, pair)
    got = make_akinci_density(ctx)(0, 1, *(pair.x[:, 0] - pair.x[:, 1]), r, pair, pair, P, 0.0)
    assert got == pytest.approx(pair.psi[1] * W(r), rel=1e-12)


# ------------------------------------------------------------------------------ diffusion
def test_fourtakas_leaves_a_hydrostatic_column_alone_and_is_molteni_without_gravity(P, ctx):
    """Fourtakas et al. (2019): for two particles whose density difference is the hydrostatic
    one (the EOS's rho at p0 + rho0 g . x_ji) the term is zero, where Molteni's is not; with
    g = 0 the two are the same term."""
    rng = np.random.default_rng(13)
    pair = _set(rng)
    _, density, _ = make_linearized_cole(ctx)
    d = pair.x[:, 1] - pair.x[:, 0]  # x_ji
    g = np.array([P.gx, P.gy, 0.0])
    rho_j = density(P.p0 + P.rho0 * g @ d, P)
    pair = pair._replace(rho=np.array([P.rho0, rho_j]))
    fourtakas = make_fourtakas(ctx, density)
    assert abs(_call(fourtakas, pair, pair, 0, 1, P)[1]) < 1e-9 * abs(_call(make_molteni(ctx), pair, pair, 0, 1, P)[1])
    assert abs(_call(make_molteni(ctx), pair, pair, 0, 1, P)[1]) > 0
    P0 = P._replace(gx=0.0, gy=0.0)
    assert _call(fourtakas, pair, pair, 0, 1, P0)[1] == pytest.approx(_call(make_molteni(ctx), pair, pair, 0, 1, P0)[1],
                                                                      rel=1e-12)


def test_molteni_is_its_formula(pair, P, ctx):
    """2 (rho_j - rho_i) x_ji . grad_i W_ij / (r^2 + eps h^2) V_j (slot 1)."""
    d, r, g = _geometry(pair, pair)
    expected = 2 * (pair.rho[1] - pair.rho[0]) * (-d @ g) / (r * r + P.eps_h2) * pair.vol[1]
    assert _call(make_molteni(ctx), pair, pair, 0, 1, P)[1] == pytest.approx(expected, rel=1e-12)


# ------------------------------------------------------------------------------ pressure
def test_corrected_pressure_with_the_identity_is_the_symmetric_and_the_difference_form(pair, P, ctx):
    """With L_i = I, CSPM's symmetric form is the BI pressure term, and the difference form is
    -(p_j - p_i) grad_i W_ij V_j."""
    _, _, g = _geometry(pair, pair)
    sym = _call(make_corrected_pressure(ctx, True), pair, pair, 0, 1, P)  # L = I (``_set``)
    assert sym[2:4] == pytest.approx(_call(make_bi_pressure(ctx), pair, pair, 0, 1, P)[2:4], rel=1e-12)
    diff = _call(make_corrected_pressure(ctx, False), pair, pair, 0, 1, P)
    assert diff[2:4] == pytest.approx(-(pair.p[1] - pair.p[0]) * g * pair.vol[1], rel=1e-12)


def test_corrected_gradient_is_exact_for_a_linear_pressure_on_a_disordered_cloud(P, ctx):
    """CSPM (Chen et al. 1999): with L_i = M_i^-1, M_i = sum_j V_j grad_i W_ij (x) x_ji, the
    difference form -sum_j (p_j - p_i) L_i grad W V_j is -grad p for p linear, whatever the
    particle positions and volumes; the uncorrected form is not."""
    rng = np.random.default_rng(14)
    n = 40
    cloud = _set(rng, n, spread=2.5)
    grad_p = np.array([1200.0, -3400.0])
    cloud = cloud._replace(p=cloud.x[:2].T @ grad_p + 500.0, vol=rng.uniform(0.5, 1.5, n) * 1e-4)
    i = int(np.argmin(np.linalg.norm(cloud.x, axis=0)))
    near = [j for j in range(n) if j != i and np.linalg.norm(cloud.x[:, i] - cloud.x[:, j]) < 2 * H]
    M = ZERO
    for j in near:
        M = _call(make_cspm_matrix(ctx), cloud, cloud, i, j, P, M)
    Li = np.linalg.inv(np.array(M).reshape(3, 3)[:2, :2])
    L = cloud.L.copy()
    L[:, i] = Li.ravel()
    cloud = cloud._replace(L=L)
    acc, plain = ZERO, ZERO
    for j in near:
        acc = _call(make_corrected_pressure(ctx, False), cloud, cloud, i, j, P, acc)
        plain = _call(make_bi_pressure(ctx), cloud, cloud, i, j, P, plain)
    assert acc[2:4] == pytest.approx(-grad_p, rel=1e-9)
    assert np.abs(np.array(plain[2:4]) + grad_p).max() > 0.05 * np.abs(grad_p).max()


def test_bi_boundary_pressure_is_its_formula(P, ctx):
    """-(p_i + p_b) n_b W_ib S_b; conservative: p_b = p_i."""
    rng = np.random.default_rng(15)
    I, B = _set(rng), _set(rng)
    _, r, _ = _geometry(I, B, 0, 1)
    for conservative, pb in ((True, I.p[0]), (False, B.p[1])):
        expected = -(I.p[0] + pb) * B.n[:2, 1] * W(r) * B.elementSize[1]
        got = _call(make_bi_boundary_pressure(ctx, conservative), I, B, 0, 1, P)[2:4]
        assert got == pytest.approx(expected, rel=1e-12)


def test_akinci_pressure_is_its_formula(P, ctx):
    """Akinci et al. (2012) eq. 10: a_i -= Psi_k (p_i/rho_i^2 + p_k/rho_k^2) grad W_ik, with
    p_k/rho_k^2 = p_i/rho_i^2 when mirrored (Band et al. 2018)."""
    rng = np.random.default_rng(16)
    I, B = _set(rng), _set(rng)
    _, _, g = _geometry(I, B, 0, 1)
    for mirrored, prk in ((True, I.pr[0]), (False, B.pr[1])):
        expected = -B.psi[1] * (I.pr[0] + prk) * g
        assert _call(make_akinci_pressure(ctx, mirrored), I, B, 0, 1, P)[5:7] == pytest.approx(expected, rel=1e-12)


# ------------------------------------------------------------------------------ viscosity
def test_viscous_terms_are_their_formulas(pair, P, ctx):
    """rho_i times the acceleration (force slot), coefficient ``P.visc``:
    MVT (Morris et al. 1997): 2 mu V_j v_ij (x_ij . grad W) / (r^2 + eps h^2);
    MGVT (Monaghan & Gingold 1983): 2 (n + 2) mu V_j (v_ij . x_ij) / (r^2 + eps h^2) grad W;
    artificial (Monaghan 1992): alpha h c0 m_j rho_i psi_ij / rho_bar grad W, approaching only."""
    d, r, g = _geometry(pair, pair)
    vij = pair.v[:2, 0] - pair.v[:2, 1]
    den = r * r + P.eps_h2
    mvt = P.visc * pair.vol[1] * vij * (d @ g) / den
    mgvt = P.visc * pair.vol[1] * (vij @ d) / den * g
    rho_bar = 0.5 * (pair.rho[0] + pair.rho[1])
    av = P.visc * pair.m[1] * pair.rho[0] * min(vij @ d, 0.0) / den / rho_bar * g
    assert _call(make_mvt(ctx), pair, pair, 0, 1, P)[2:4] == pytest.approx(mvt, rel=1e-12)
    assert _call(make_mgvt(ctx), pair, pair, 0, 1, P)[2:4] == pytest.approx(mgvt, rel=1e-12)
    assert _call(make_artificial_viscosity(ctx), pair, pair, 0, 1, P)[2:4] == pytest.approx(av, rel=1e-12, abs=1e-300)
    for make in (make_mvt, make_mgvt, make_artificial_viscosity):  # the wall form: its own coefficient
        wall = _call(make(ctx, wall=True), pair, pair, 0, 1, P)[2:4]
        bulk = _call(make(ctx), pair, pair, 0, 1, P)[2:4]
        assert wall == pytest.approx(bulk * P.wall_visc / P.visc, rel=1e-12, abs=1e-300)


def test_boundary_viscous_term_is_its_formula_and_zero_behind_the_plane(P, ctx):
    """WCSPH-BI no-slip wall term: c (v_i - v_b) d / (d^2 + eps h^2) W_ib S_b with
    d = (x_i - x_b) . n_b < 0 on the fluid side; a particle behind the element's plane (d > 0,
    round a convex corner) gets nothing, where 1/d would drive the slip instead of damping it."""
    rng = np.random.default_rng(17)
    I, B = _set(rng), _set(rng)
    B.n[:, 1] = 0.0
    for side in (-1.0, 1.0):
        B.n[:2, 1] = side * (I.x[:2, 0] - B.x[:2, 1]) / np.linalg.norm(I.x[:2, 0] - B.x[:2, 1])
        d_vec, r, _ = _geometry(I, B, 0, 1)
        d = d_vec @ B.n[:2, 1]
        expected = P.wall_visc * min(d, 0.0) / (min(d, 0.0) ** 2 + P.eps_h2) * W(r) * B.elementSize[1] * (
            I.v[:2, 0] - B.v[:2, 1])
        got = _call(make_boundary_viscosity(ctx, False), I, B, 0, 1, P)[2:4]
        assert got == pytest.approx(expected, rel=1e-12, abs=1e-300)
        if side < 0:  # in front of the plane: it opposes the slip
            assert got @ (I.v[:2, 0] - B.v[:2, 1]) < 0
        else:
            assert np.all(got == 0.0)


def test_xsph_is_its_formula(pair, P, ctx):
    """momentum form: a_i += eps/dt V_j (v_j - v_i) W_ij (wall: wall_xsph/dt Psi/rho0);
    position form: v^_i += eps m_j (v_j - v_i) / rho_ij W_ij, rho_ij the mean."""
    _, r, _ = _geometry(pair, pair)
    vji = pair.v[:2, 1] - pair.v[:2, 0]
    assert _call(make_xsph(ctx), pair, pair, 0, 1, P)[5:7] == pytest.approx(P.xsph_dt * pair.vol[1] * W(r) * vji,
                                                                          rel=1e-12)
    wall = P.wall_xsph_dt * pair.psi[1] / P.rho0 * W(r) * vji
    assert _call(make_xsph(ctx, wall=True), pair, pair, 0, 1, P)[5:7] == pytest.approx(wall, rel=1e-12)
    rho_ij = 0.5 * (pair.rho[0] + pair.rho[1])
    pos = P.xsph_epsilon * pair.m[1] / rho_ij * W(r) * vji
    assert _call(make_xsph_position(ctx), pair, pair, 0, 1, P, (0.0, 0.0, 0.0))[:2] == pytest.approx(pos, rel=1e-12)


# ------------------------------------------------------------------------------ collision
def test_dpc_removes_the_approach_velocity_of_a_close_pair(P, ctx):
    """DPC (Jandaghian et al. 2021): an approaching pair closer than l0/2 collides
    inelastically (k = 1): applied to both particles (equal masses), the velocity changes
    remove their relative normal velocity, keep the tangential one and the momentum."""
    l0 = H / 2
    Pd = P._replace(eps_h2=0.0, dpc_scale=H / (0.5 * l0), dpc_w_half_inv=1.0 / W(H), dpc_lambda=1.0,
                    dpc_lambda_pmax=1e4, dpc_pmin=0.0)
    rng = np.random.default_rng(17)
    pair = _set(rng)
    x = np.zeros((3, 2))
    x[:2, 1] = 0.3 * l0 * np.array([0.6, 0.8])
    v = np.zeros((3, 2))
    v[:2, 0] = [0.5, 0.2]  # toward particle 1 along x_ji and sideways
    v[:2, 1] = [-0.4, 0.1]
    pair = pair._replace(x=x, v=v, m=np.full(2, 0.1))
    dv0 = _call(make_dpc(ctx), pair, pair, 0, 1, Pd, (0.0, 0.0, 0.0))[:2]
    dv1 = _call(make_dpc(ctx), pair, pair, 1, 0, Pd, (0.0, 0.0, 0.0))[:2]
    e = x[:2, 1] / np.linalg.norm(x[:2, 1])
    v_after = v[:2] + np.stack([dv0, dv1], axis=1)
    assert (v_after[:, 0] - v_after[:, 1]) @ e == pytest.approx(0.0, abs=1e-12)
    assert dv0 + dv1 == pytest.approx(np.zeros(2), abs=1e-12)
    t = np.array([-e[1], e[0]])
    assert (v_after[:, 0] - v_after[:, 1]) @ t == pytest.approx((v[:2, 0] - v[:2, 1]) @ t, rel=1e-12)


# ------------------------------------------------------------------------------ EOS
@pytest.mark.parametrize("make", [make_tait, make_cole, make_linearized_cole])
def test_eos_inverse_and_sound_speed(make, P, ctx):
    """rho(p(rho)) = rho; c(rho0) = c0; c^2 = dp/drho (central difference)."""
    fns = make(ctx, False) if make is make_tait else make(ctx)
    pressure, density, sound = fns
    Pe = P._replace(eos_b=P.c2 * P.rho0 / 7.0, gamma=7.0, gamma_inv=1 / 7.0)
    for rho in (995.0, 1000.0, 1012.0):
        assert density(pressure(rho, Pe), Pe) == pytest.approx(rho, rel=1e-12)
        dr = 1e-3
        slope = (pressure(rho + dr, Pe) - pressure(rho - dr, Pe)) / (2 * dr)
        assert sound(rho, Pe) ** 2 == pytest.approx(slope, rel=1e-7)
    assert sound(Pe.rho0, Pe) == pytest.approx(Pe.c0, rel=1e-12)


# ------------------------------------------------------------------------------ shifting
def _near_wall(ctx, P, per_h):
    """(gradient sum with the wall, fluid-only gradient sum, position divergence, Shepard
    sum) at a particle about 0.8 h above a wall of boundary elements, a lattice of h/per_h."""
    from wcsph.physics.shifting import make_shift_boundary, make_shift_term

    dp = H / per_h
    gx, gy = np.arange(-6 * per_h, 6 * per_h + 1) * dp, (np.arange(0, 3 * per_h) + 0.5) * dp  # above y = 0
    X, Y = np.meshgrid(gx, gy)
    n = X.size
    x = np.zeros((3, n))
    x[0], x[1] = X.ravel(), Y.ravel()
    rho = np.full(n, 1000.0)
    fluid = Set(x, np.zeros((3, n)), rho, np.zeros(n), np.zeros(n), np.full(n, dp * dp), rho * dp * dp,
                np.zeros(n), np.zeros(n), np.zeros((3, n)), np.zeros(n), np.zeros((4, n)))
    nb = 8 * len(gx)
    size = len(gx) * dp / nb
    xb = np.zeros((3, nb))
    xb[0] = gx[0] - dp / 2 + (np.arange(nb) + 0.5) * size
    normal = np.zeros((3, nb))
    normal[1] = -1.0  # out of the fluid
    wall = Set(xb, np.zeros((3, nb)), np.zeros(nb), np.zeros(nb), np.zeros(nb), np.zeros(nb), np.zeros(nb),
               np.zeros(nb), np.zeros(nb), normal, np.full(nb, size), np.zeros((4, nb)))
    i = int(np.argmin(np.abs(x[0]) + np.abs(x[1] - 0.8 * H)))
    Ps = P._replace(shift_w_dp_inv=1.0)
    acc, shepard = (0.0,) * 11, 0.0
    for j in range(n):
        r = np.linalg.norm(x[:, i] - x[:, j])
        if j != i and r < 2 * H:
            acc = _call(make_shift_term(ctx, False), fluid, fluid, i, j, Ps, acc)
        if r < 2 * H:
            shepard += W(r) * dp * dp
    fluid_only = np.array(acc[3:5])
    for b in range(nb):
        if np.linalg.norm(x[:, i] - xb[:, b]) < 2 * H:
            acc = _call(make_shift_boundary(ctx), fluid, wall, i, b, Ps, acc)
    return np.array(acc[3:5]), fluid_only, acc[6], shepard


def test_shifting_sums_close_with_the_boundary_integral(P, ctx):
    """Next to a wall of boundary elements (the WCSPH-BI identity, Gauss's theorem on the
    kernel): sum_j grad_i W_ij V_j + sum_b n_b W_ib S_b = 0, and the position divergence
    sum_j x_ji . grad_i W_ij V_j + sum_b x_bi . n_b W_ib S_b = d gamma_i, gamma_i the
    kernel's share inside the fluid (its Shepard sum), up to the lattice's quadrature error,
    which shrinks with h/dp (measured: 3 % of the one-sided sum at h = 2 dp, 1.3 % at 4 dp).
    The fluid's sum alone is a free surface's, of the size of 1/h."""
    coarse = _near_wall(ctx, P, 2)
    fine = _near_wall(ctx, P, 4)
    for closed, fluid_only, div, shepard in (coarse, fine):
        assert fluid_only[1] > 0.2 / H
        assert 0.85 < shepard < 0.97  # a part of the support is cut by the wall
        assert div == pytest.approx(2 * shepard, rel=0.02)
    assert np.abs(coarse[0]).max() < 0.05 * coarse[1][1]
    assert np.abs(fine[0]).max() < 0.02 * fine[1][1]
    assert np.abs(fine[0]).max() < 0.6 * np.abs(coarse[0]).max()


@pytest.mark.parametrize("boundary", ["elements", "particles"])
def test_shifting_near_walls_none_leaves_a_particle_by_a_wall_where_it_is(P, ctx, boundary):
    """``shifting_near_walls = "none"`` (TNL-SPH's PST): one wall neighbour within the support,
    an element or a boundary particle, and the particle's shift is zero, its density kept;
    with "complete" (the default) the same sums shift it."""
    from wcsph.physics.shifting import make_shift_boundary, make_shift_store, make_shift_term, make_shift_wall_particles

    rng = np.random.default_rng(7)
    fluid, wall = _set(rng, 3), _set(rng, 1)
    wall_term = make_shift_boundary(ctx) if boundary == "elements" else make_shift_wall_particles(ctx)
    Ps = P._replace(shift_w_dp_inv=1.0, shift_d=1e-4, vmax=1.0, shift_surface=0.0, shift_max=1.0)
    acc = (0.0,) * 11
    for j in (1, 2):
        acc = _call(make_shift_term(ctx, True), fluid, fluid, 0, j, Ps, acc)
    acc = _call(wall_term, fluid, wall, 0, 0, Ps, acc)
    assert acc[10] == 1.0
    out = {}
    for near_walls in (True, False):
        _, store = make_shift_store(ctx, False, True, near_walls)
        Iw = namedtuple("I", "v rho corr rho_corr")(fluid.v, fluid.rho, np.zeros((3, 3)), np.zeros(3))
        store(0, Iw, Ps, acc)
        out[near_walls] = (Iw.corr[:, 0].copy(), Iw.rho_corr[0])
    assert np.abs(out[True][0]).max() > 0.0 and out[True][1] != fluid.rho[0]
    assert np.all(out[False][0] == 0.0) and out[False][1] == fluid.rho[0]
