"""Geometry of a case: wall particles of closed polygons (the classic model's boundary
particles, as the WCSPH-BI model's elements)."""
import math

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
    the fluid's lattice, exactly the particles of the same obstacle box, each with its cell."""
    got, cells = geometry.polygon_particles(BOX, 0.05, layers)
    want, cell = geometry.obstacle_particles({"min": [0.2, 0.1], "max": [0.6, 0.3]}, 0.05, layers)
    assert got.shape[1] > 0 and _set(got) == _set(want) and cell == pytest.approx(0.05 ** 2)
    assert cells == pytest.approx(np.full(got.shape[1], 0.05 ** 2))


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("width", [6.0, 6.44, 6.5, 6.56])
def test_a_box_of_any_width_is_felt_by_the_fluid_where_its_face_is(dim, width):
    """A fluid lattice that starts half a spacing from an obstacle's face sums to the density
    of fluid at rest (wall particles counted with their pseudo-mass, the summation density's
    dummy-particle limit), however many dp the box is across: its wall lattice is fitted to
    it. A lattice of dp from the box's lower corner leaves a face up to dp behind where it is
    drawn (6.44 dp, SPHERIC 2's box at dp = 0.025: a gap of 0.44 dp, the sum 13 % low)."""
    from wcsph.physics.kernels import kernel_numpy

    dp, h = 0.025, 0.05
    w, _ = kernel_numpy("wendland", dim, h)
    mass = 1000.0 / geometry.lattice_density_sum(w, dim, dp, h)
    side = width * dp
    box = {"min": [0.0] * dim, "max": [side] * dim}
    walls, cell = geometry.obstacle_particles(box, dp, 4)
    # fluid beyond the upper face along x (the face a lattice from the lower corner misses)
    lo, hi = [side] + [-4 * dp] * (dim - 1), [side + 6 * dp] + [side + 4 * dp] * (dim - 1)
    fluid = geometry.lattice(lo, hi, dp)
    i = np.argmin(np.sum((fluid - np.array([side + dp / 2] + [side / 2] * (dim - 1))[:, None]) ** 2, axis=0))
    r_f = np.linalg.norm(fluid - fluid[:, i:i + 1], axis=0)
    r_w = np.linalg.norm(walls - fluid[:, i:i + 1], axis=0)
    rho = mass * w(r_f).sum() + mass * cell / dp ** dim * w(r_w).sum()
    assert rho == pytest.approx(1000.0, rel=0.01)



def test_a_tank_of_any_size_has_its_walls_half_a_spacing_behind_its_faces():
    """SPHERIC 2's tank (3.22 x 1 x 1 m, open top) at dp = 0.025 (128.8 spacings long): the
    wall layers nearest each face lie half a spacing behind it (the far wall 0.2 dp further
    on the lattice of dp from the corner), ``layers`` deep, none above the open top."""
    dp, layers = 0.025, 4
    tank = {"min": [0.0, 0.0, 0.0], "max": [3.22, 1.0, 1.0], "open_top": True}
    x, cell = geometry.tank_particles(tank, dp, layers)
    s = np.array([3.22 / 129, 1.0 / 40, 1.0 / 40])
    assert cell == pytest.approx(np.prod(s))
    for a in range(3):
        assert x[a].min() == pytest.approx(-(layers - 0.5) * s[a])
        inner = x[a][x[a] < 0]
        assert inner.max() == pytest.approx(-0.5 * s[a])
        if a < 2:
            assert x[a].max() == pytest.approx(tank["max"][a] + (layers - 0.5) * s[a])
            assert x[a][x[a] > tank["max"][a]].min() == pytest.approx(tank["max"][a] + 0.5 * s[a])
    assert x[2].max() < 1.0


def test_a_counter_clockwise_polygon_is_walled_outside():
    """A container's outline, counter-clockwise (the fluid inside), is sampled outside it in
    ``layers`` rows, row k at (k + 1/2) dp from the outline (arcs round its corners), the
    particles about dp apart along each row (0.85-1.05 dp: a chord round a corner is shorter) and their cells adding up to the area the rows
    stand for: the band ``layers`` dp wide round the outline."""
    pts = np.array(BOX[::-1], dtype=float)
    dp, layers = 0.05, 2
    x, cell = geometry.polygon_particles(pts, dp, layers)
    assert x.shape[1] > 0 and not geometry._in_polygon(x, pts, 0.0).any()
    d = geometry._outline_distance(x, pts) / dp - 0.5
    assert np.allclose(d, np.round(d), atol=1e-3) and set(np.round(d).astype(int)) == {0, 1}
    gaps = np.sqrt(((x[:, :, None] - x[:, None, :]) ** 2).sum(axis=0)) + 9 * np.eye(x.shape[1])
    assert np.all(gaps.min(axis=0) > 0.85 * dp) and np.all(gaps.min(axis=0) < 1.05 * dp)  # (a chord round a corner)
    t = layers * dp
    band = 2 * (0.4 + 0.2) * t + math.pi * t * t  # the band round the outline: sides and four quarter discs
    assert cell.sum() == pytest.approx(band, rel=0.01)


@pytest.mark.parametrize("body", [True, False])
def test_a_curved_wall_is_felt_alike_all_round(body):
    """Fekken's cylinder (R = 20 dp, 96 sides), as a body or as a round container: the kernel
    sum of its wall particles' cells at points half a spacing and one spacing off the outline
    on the fluid's side is the same all round within 0.5 %, and it stands to the kernel's
    integral over the band of solid the rows stand for (4 dp deep behind the circle) as a
    straight wall's lattice stands to its own (2-5 % below, the sum's quadrature error next to
    a wall) within 1.5 points. On the fluid's lattice (the sampling before) its standard
    deviation round the body was 19 % half a spacing off, 24 % one spacing off: a staircase."""
    from wcsph.physics.kernels import kernel_numpy

    dp, h, R = 0.05, 0.1, 1.0
    w, _ = kernel_numpy("wendland", 2, h)
    a = np.linspace(0.0, 2 * np.pi, 96, endpoint=False)
    pts = R * np.stack([np.cos(a), np.sin(a)], axis=1)
    pts = pts[::-1] if body else pts
    x, cell = geometry.polygon_particles(pts, dp, 4)
    rr, tt = np.meshgrid(R + (-1 if body else 1) * 4 * dp * (np.arange(400) + 0.5) / 400,
                         np.linspace(0.0, 2 * np.pi, 20000, endpoint=False), indexing="ij")
    da = 4 * dp / 400 * rr * 2 * np.pi / 20000
    flat = geometry.lattice([-2.0, -4 * dp], [2.0, 0.0], dp)
    fx, fy = np.meshgrid(np.linspace(-0.3, 0.3, 1201), -4 * dp * (np.arange(400) + 0.5) / 400)
    for off in (0.5, 1.0):
        r = R + (off if body else -off) * dp * np.cos(np.pi / 96)  # off the sides' middles and corners alike
        ang = np.linspace(0.0, 2 * np.pi, 360, endpoint=False)
        at = r * np.stack([np.cos(ang), np.sin(ang)])
        s = (w(np.sqrt(((at[:, :, None] - x[:, None, :]) ** 2).sum(axis=0))) * cell).sum(axis=1)
        solid = (w(np.hypot(rr * np.cos(tt) - r, rr * np.sin(tt))) * da).sum()
        straight = (w(np.hypot(flat[0], flat[1] - off * dp)) * dp * dp).sum()
        straight_solid = w(np.hypot(fx, fy - off * dp)).sum() * (0.6 / 1200) * (4 * dp / 400)
        assert s.std() < 0.005 * s.mean()
        assert s.mean() / solid == pytest.approx(straight / straight_solid, abs=0.015)


def test_a_polygon_thinner_than_its_rows_gets_each_particle_once():
    """A plate 3 dp thick drawn as a polygon, walled 4 rows deep: the second row is the plate's
    middle line, met from both sides, and holds one particle per dp of it: the plate gets the
    particles of the same obstacle box, no two nearer than dp/2 (without the check the middle
    line had each particle twice)."""
    dp = 0.05
    plate = np.array([[0.0, 0.0], [0.0, 3 * dp], [1.0, 3 * dp], [1.0, 0.0]])  # clockwise: a body
    x, cell = geometry.polygon_particles(plate, dp, 4)
    gaps = np.sqrt(((x[:, :, None] - x[:, None, :]) ** 2).sum(axis=0)) + 9 * np.eye(x.shape[1])
    assert gaps.min() > 0.5 * dp and geometry._in_polygon(x, plate, 0.0).all()
    want, _ = geometry.obstacle_particles({"min": [0.0, 0.0], "max": [1.0, 3 * dp]}, dp, 4)
    assert _set(x) == _set(want) and cell == pytest.approx(np.full(x.shape[1], dp * dp))


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


@pytest.mark.parametrize("model", ["classic", "bi"])
def test_a_counter_clockwise_polygon_holds_the_block_fluid_inside_it(model):
    """A container polygon (counter-clockwise: the fluid on the left, inside), a cup with a
    sloping side, and a fluid block larger than it: the fluid is kept inside it and only there,
    every particle at least dp/2 from its outline, all the block's lattice points so placed;
    its walls (particles, elements) lie on the other side. Before the change the fluid was
    carved as from a body: the particles outside the cup were kept and those inside removed."""
    cup = [[0.0, 0.0], [0.8, 0.0], [1.0, 0.6], [0.0, 0.6]]
    dp = 0.05
    case = validate({"dim": 2, "dp": dp, "time": {"end": 0.1}, "model": {"name": model},
                     "domain": {"min": [-0.3, -0.3], "max": [1.3, 1.0]},
                     "fluid": [{"min": [-0.2, -0.2], "max": [1.2, 0.4]}],
                     "polygon": [{"points": cup, "closed": True}]})
    fluid, walls, _, _ = geometry.build(case)
    x, pts = fluid["x"], np.asarray(cup, dtype=float)
    assert np.all(geometry._in_polygon(x, pts, 0.0)) and np.all(geometry._outline_distance(x, pts) >= 0.5 * dp - 1e-9)
    want = geometry.lattice([-0.2, -0.2], [1.2, 0.4], dp)
    want = want[:, geometry._in_polygon(want, pts, 0.0) & (geometry._outline_distance(want, pts) >= 0.5 * dp - 1e-9)]
    assert x.shape[1] == want.shape[1] > 100
    if model == "classic":
        assert not geometry._in_polygon(walls["x"], pts, 0.0).any()
    else:  # each element's normal points out of the fluid: a step along it leaves the cup
        assert not geometry._in_polygon(walls["x"] + 0.01 * walls["n"], pts, 0.0).any()
        assert geometry._in_polygon(walls["x"] - 0.01 * walls["n"], pts, 0.0).all()


def test_a_polygon_that_leaves_no_fluid_says_which_way_it_holds_it():
    case = validate(dict({k: v for k, v in CLASSIC.items() if k != "tank"}, domain={"min": [-0.5, -0.5], "max": [1.5, 1.5]},
                         polygon=[{"points": [[2.0, 0.0], [3.0, 0.0], [3.0, 1.0], [2.0, 1.0]], "closed": True}]))
    with pytest.raises(CaseError, match=r"polygon: .*inside when they run counter-clockwise"):
        geometry.build(case)


@pytest.mark.parametrize("model,source", [("classic", "box"), ("bi", "box"), ("bi", "surface")])
def test_wall_meshes_carve_the_fluid_blocks_as_obstacles_do(model, source, box_stl):
    """A block of fluid (a box, or a closed surface filled with the lattice) with a closed
    body mesh in it (``fluid_side = "outside"``) and a tank mesh smaller than the block
    (``"inside"``): the fluid keeps exactly the block's lattice points inside the tank and
    outside the body, each at least dp/2 from both surfaces (an obstacle box in the body's
    place would leave the same points). Before the change the blocks ignored wall meshes: the
    body was full of water and water stood outside the tank."""
    dp = 0.1
    block = ({"min": [-0.2] * 3, "max": [1.2, 1.2, 0.6]} if source == "box"
             else {"surface": box_stl("water.stl", [-0.2] * 3, [1.2, 1.2, 0.6])})
    case = validate({"dim": 3, "dp": dp, "time": {"end": 0.1}, "model": {"name": model},
                     "domain": {"min": [-0.6] * 3, "max": [1.6] * 3},
                     "fluid": [block],
                     "walls": [{"mesh": box_stl("tank.stl", [0.0] * 3, [1.0] * 3), "fluid_side": "inside"},
                               {"mesh": box_stl("body.stl", [0.3] * 3, [0.7, 0.7, 1.0])}]})
    fluid, _, _, _ = geometry.build(case)
    want = geometry.lattice([0.0] * 3, [1.0, 1.0, 0.6], dp)
    body = geometry._inside(want, np.array([0.3] * 3) - 0.5 * dp, np.array([0.7, 0.7, 1.0]) + 0.5 * dp, 1e-6 * dp)
    assert _set(fluid["x"]) == _set(want[:, ~body]) and fluid["x"].shape[1] == 600 - 4 * 4 * 3


@pytest.mark.parametrize("model", ["classic", "bi"])
def test_a_wall_point_file_clears_the_fluid_lattice_within_dp_2(model, tmp_path):
    """A wall of points from a file (no solid side) across a fluid box, on the box's lattice:
    the fluid keeps every lattice point but those within dp/2 of a wall point (the column
    the wall stands on); before the change a fluid particle sat on each wall point."""
    dp = 0.05
    ys = 0.025 + dp * np.arange(10)
    path = tmp_path / "wall.csv"
    path.write_text("x,y,nx,ny,elementSize\n" + "".join(f"0.225,{y},1.0,0.0,{dp}\n" for y in ys))
    case = validate(dict(CLASSIC, model={"name": model}, walls=[{"file": str(path)}]))
    fluid, _, _, _ = geometry.build(case)
    want = geometry.lattice([0.0, 0.0], [1.0, 0.5], dp)
    want = want[:, np.abs(want[0] - 0.225) > 1e-9]
    assert _set(fluid["x"]) == _set(want) and fluid["x"].shape[1] == 20 * 10 - 10


def test_an_open_polygon_clears_the_fluid_lattice_within_dp_2():
    """A wall polyline across a fluid box, off the lattice by a tenth of dp: the fluid keeps
    the box's lattice points at least dp/2 from it (before, particles sat on the wall)."""
    dp = 0.05
    case = validate(dict(CLASSIC, model={"name": "bi"}, polygon=[{"points": [[0.23, 0.0], [0.23, 0.3], [0.5, 0.3]]}]))
    fluid, _, _, _ = geometry.build(case)
    want = geometry.lattice([0.0, 0.0], [1.0, 0.5], dp)
    d = geometry._outline_distance(want, np.array([[0.23, 0.0], [0.23, 0.3], [0.5, 0.3]]), closed=False)
    assert _set(fluid["x"]) == _set(want[:, d >= 0.025 * (1 - 1e-6)]) and fluid["x"].shape[1] == 200 - 6


def test_a_wall_mesh_that_leaves_no_fluid_says_which_side_it_holds(box_stl):
    case = validate({"dim": 3, "dp": 0.1, "time": {"end": 0.1}, "domain": {"min": [-0.6] * 3, "max": [1.6] * 3},
                     "fluid": [{"min": [0.2] * 3, "max": [0.8] * 3}],
                     "walls": [{"mesh": box_stl("body.stl", [0.0] * 3, [1.0] * 3)}]})
    with pytest.raises(CaseError, match=r"walls: .*fluid_side"):
        geometry.build(case)


@pytest.mark.parametrize("points,closed,message", [
    ([[0.5, 0.5], [0.6, 0.5]], True, "at least three points"),
    ([[0.5, 0.5], [0.7, 0.7], [0.7, 0.5], [0.5, 0.7]], True, r"sides 0 \(0 -> 1\) and 2 \(2 -> 3\) cross"),
    ([[0.5, 0.5], [0.6, 0.5], [0.7, 0.5]], True, "encloses no area"),
    ([[0.5, 0.5], [0.6, 0.5], [0.6, 0.5], [0.6, 0.6]], True, "points 1 and 2 are the same point"),
    ([[0.5, 0.5], [0.5, 0.5]], False, "points 0 and 1 are the same point"),
])
def test_a_polygon_that_makes_no_wall_is_one_line_naming_its_points(points, closed, message):
    """Points that make no wall: a side of no length; closed, fewer than three points, no
    area, or sides that cross (a bow tie: its fluid side would change along it). Before, each
    ran, with walls of no area or a fluid side that changed halfway."""
    with pytest.raises(CaseError, match=r"polygon\[0\]\.points: .*" + message):
        validate(dict(CLASSIC, polygon=[{"points": points, "closed": closed}]))
    validate(dict(CLASSIC, polygon=[{"points": [[0.5, 0.5], [0.5, 0.7], [0.7, 0.7], [0.7, 0.5]], "closed": True}]))


def test_an_open_polygon_with_wall_particles_is_one_line():
    case = validate(dict(CLASSIC, polygon=[{"points": [[0.2, 0.1], [0.6, 0.1]], "closed": False}]))
    with pytest.raises(CaseError, match=r"polygon\[0\]\.closed: an open polygon has no solid side"):
        geometry.build(case)


def test_a_compressed_lattice_spaces_its_layers_by_the_column_density():
    """``compressed_lattice``: with rho / rho0 = 1 the plain lattice; with a density growing
    with depth the layers sit closer by its ratio, the lowest dp / 2 above the bottom, and the
    top layer within dp / 2 of where a lattice holding the column's mass ends."""
    lo, hi, dp = [0.0, 0.0], [0.4, 1.0], 0.02
    plain = geometry.compressed_lattice(lo, hi, dp, lambda z: np.ones_like(z))
    assert _set(plain) == _set(geometry.lattice(lo, hi, dp))
    k = 0.1  # rho / rho0 = 1 + k depth: the column holds 1 + k / 2 times the plain mass
    x = geometry.compressed_lattice(lo, hi, dp, lambda z: 1.0 + k * np.asarray(z))
    ys = np.unique(np.round(x[1], 12))
    assert x.shape[1] == 20 * round(50 * (1 + k / 2))  # 20 columns of 52.5 -> 52 or 53 layers
    assert ys[0] == pytest.approx(0.5 * dp / (1 + k), rel=1e-3)
    mid = 0.5 * (ys[1:] + ys[:-1])
    assert np.allclose(np.diff(ys), dp / (1 + k * (1.0 - mid)), rtol=1e-3)
    assert abs(ys[-1] + 0.5 * np.diff(ys)[-1] - 1.0) <= 0.501 * dp


def test_a_summation_density_column_starts_at_rest_at_its_level():
    """A classic (summation-density) column under gravity is sampled compressed, so that its
    summed density is the hydrostatic one (the EOS at rho0 g depth, as a continuity density
    starts) and it keeps the case's water level; a plain lattice would settle lower by the mean
    compression (2.5 % of the depth at c0 = 10 m/s, 0.5 m: 0.6 dp here). With a gravity ramp
    the column starts unloaded, on the plain lattice."""
    from wcsph.solver.simulation import Simulation

    case = dict(CLASSIC, dp=0.02, physics={"speed_of_sound": 10.0, "gravity": [0.0, -9.81]})
    sim = Simulation(validate(case))
    sim.state.evaluate(sim.P)  # the summation density
    x, rho = (a.astype(float) for a in sim.host(sim.fluid, "x", "rho"))
    depth = 0.5 - x[1]
    inner = (depth > 0.1) & (x[1] > 0.1) & (np.abs(x[0] - 0.5) < 0.3)
    want = np.array([sim.model.q.eos_density(sim.P.p0 + 1000.0 * 9.81 * z, sim.P) for z in depth[inner]])
    assert rho[inner].min() > 1008.0  # compressed by 1-4 % here
    assert np.allclose(rho[inner], want, rtol=0.003)
    assert abs(x[1].max() - (0.5 - 0.01)) <= 0.01 + 1e-6  # top layer within dp / 2 of the plain one's
    ramped = Simulation(validate(dict(case, physics=dict(case["physics"], gravity_ramp_time=0.5))))
    assert ramped.host(ramped.fluid, "x")[0].shape[1] == 50 * 25 < x.shape[1]


@pytest.mark.parametrize("model, warned", [("classic", True), ("bi", False)])
def test_an_obstacle_thinner_than_dp_is_named_for_wall_particles(model, warned):
    """A 6 mm plate at dp = 0.02: one layer of wall particles of 0.3 of a particle's mass per
    spacing (before the fitted lattice: none at all). The classic model warns, naming the
    obstacle and the axis; boundary elements have no thickness and do not."""
    case = validate(dict(CLASSIC, dp=0.02, model={"name": model},
                         obstacle=[{"min": [0.6, 0.0], "max": [0.606, 0.3]}, {"min": [0.2, 0.6], "max": [0.3, 0.7]}]))
    lines = geometry.thin_obstacles(case)
    assert (lines != []) == warned
    if warned:
        assert len(lines) == 1 and lines[0].startswith("obstacle[0] is 0.3 dp thick along axis 0")


@pytest.mark.parametrize("model, warned", [("classic", True), ("bi", False)])
def test_a_polygon_thinner_than_dp_in_places_is_named_for_wall_particles(model, warned):
    """A block with a fin 0.6 dp thick and 10 dp tall standing on it: the rows of wall
    particles stop where the solid is thinner than they are deep, so the fin gets none and
    0.93 m of outline (its two sides, less the ends its neighbours reach) is bare. The
    classic model warns, naming the polygon; a block without the fin, a 60-degree wedge and
    the boundary elements do not."""
    fin = [[0.2, 0.1], [0.2, 0.3], [0.5, 0.3], [0.5, 0.8], [0.53, 0.8], [0.53, 0.3], [0.8, 0.3], [0.8, 0.1]]
    wedge = [[0.5, 0.1], [0.3, 0.1 + 0.2 * math.sqrt(3)], [0.7, 0.1 + 0.2 * math.sqrt(3)]][::-1]
    block = [[0.2, 0.1], [0.2, 0.3], [0.8, 0.3], [0.8, 0.1]]
    polys = [{"points": p, "closed": True} for p in (block, fin, wedge)]
    lines = geometry.thin_obstacles(validate(dict(CLASSIC, model={"name": model}, polygon=polys)))
    assert (lines != []) == warned
    if warned:
        assert len(lines) == 1 and lines[0].startswith("polygon[1] has 0.93 m of its outline more than 1.5 dp")


def test_a_polygon_thinner_than_dp_everywhere_is_one_line():
    """A sliver 0.2 dp thick gets no wall particle at all: a case error naming it, not a wall
    that is not there."""
    sliver = [[0.2, 0.6], [0.2, 0.61], [0.8, 0.61], [0.8, 0.6]]
    case = validate(dict(CLASSIC, polygon=[{"points": sliver, "closed": True}]))
    with pytest.raises(CaseError, match=r"polygon\[0\]: thinner than dp = 0.05 everywhere"):
        geometry.build(case)


def test_a_fluid_box_its_lattice_falls_short_of_is_named():
    """A box of fluid holds floor(L / dp) spacings of dp along each axis: SPHERIC 2's
    reservoir (1.228 x 1 x 0.55 m) at dp = 0.035 is 0.98 m wide and 0.525 m deep, at 0.02
    0.54 m deep. The start names each box and axis short by more than 1 % and a dp that fills
    it; at the case's own dp = 0.025 (1.225 m long, 0.2 % short) nothing is said. A summation
    density's column at rest rounds its layers to the nearest and its depth is not named; a
    fitted box (the shipped case's) is sampled as drawn and is not named either."""
    from wcsph.case.config import load

    plain = [("fluid", [{"min": [1.992, 0.0, 0.0], "max": [3.22, 1.0, 0.55]}])]
    assert geometry.short_blocks(load("spheric2_3d", plain)) == []
    assert geometry.short_blocks(load("spheric2_3d", [("dp", 0.035)])) == []  # fill = "fitted"
    lines = geometry.short_blocks(load("spheric2_3d", plain + [("dp", 0.035)]))
    assert [line.split(" (")[0] for line in lines] == [
        "fluid[0] is 1 m along axis 1 and holds 28 spacings of dp = 0.035 m",
        "fluid[0] is 0.55 m along axis 2 and holds 15 spacings of dp = 0.035 m"]
    assert "0.525 m of fluid, 4.5 % short" in lines[1] and lines[1].endswith("(e.g. 0.03438 m), or fill = \"fitted\" the box as drawn")
    case = load("spheric2_3d", plain + [("dp", 0.02)])
    assert [line.split(" (")[0] for line in geometry.short_blocks(case)] == [
        "fluid[0] is 0.55 m along axis 2 and holds 27 spacings of dp = 0.02 m"]
    assert geometry.short_blocks(case, rounded_top=True) == []


def _outline_mesh(path, loops):
    """A 2D mesh of line segments along each closed loop ((M, 2) points, in its order) into
    ``path``; returns the path."""
    import meshio

    pts, segs = [], []
    for loop in loops:
        base = len(pts)
        pts += [list(p) + [0.0] for p in loop]
        segs += [[base + i, base + (i + 1) % len(loop)] for i in range(len(loop))]
    meshio.write(path, meshio.Mesh(np.array(pts, dtype=float), [("line", np.array(segs))]))
    return str(path)


def test_a_2d_wall_mesh_gets_the_wall_particles_of_the_same_polygon(tmp_path):
    """The classic model's wall particles of a 2D mesh are a polygon's, in rows along its
    outlines (``polygon_particles``), whichever way the file runs: a body (a 24-gon, fluid
    outside) and a tank outline (fluid inside) give the same points and cells as the same
    outlines given as ``[[polygon]]`` started at the same vertex, the one of least x (then
    y: a row without corners is cut evenly from where its outline starts). Until 2026-12-08
    a 2D mesh was sampled on the fluid's lattice: a staircase round a curved body."""
    body = [[0.5 + 0.15 * math.cos(a), 0.35 + 0.15 * math.sin(a)] for a in np.linspace(0, 2 * math.pi, 24, endpoint=False)]
    tank = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]  # counter-clockwise: the fluid inside
    base = {"dim": 2, "dp": 0.05, "time": {"end": 0.1}, "model": {"name": "classic"},
            "fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.6]}]}
    cw = body[::-1]  # clockwise: a body
    k = min(range(len(cw)), key=lambda i: tuple(cw[i]))
    polygons = validate(dict(base, polygon=[{"points": tank, "closed": True},
                                            {"points": cw[k:] + cw[:k], "closed": True}]))
    _, want, _, _ = geometry.build(polygons)
    for order in (1, -1):  # the file's own direction does not matter: read_surface orients it
        meshes = validate(dict(base, walls=[
            {"mesh": _outline_mesh(tmp_path / f"tank{order}.vtk", [tank[::order]]), "fluid_side": "inside"},
            {"mesh": _outline_mesh(tmp_path / f"body{order}.vtk", [body[::order]]), "fluid_side": "outside"}]))
        _, got, _, _ = geometry.build(meshes)
        assert got["x"].shape == want["x"].shape and np.array_equal(np.sort(got["body"]), np.sort(want["body"]))
        d = np.sqrt(((got["x"][:, :, None] - want["x"][:, None, :]) ** 2).sum(axis=0))
        match = d.argmin(axis=1)  # the loops may start elsewhere: each point's nearest
        assert d.min(axis=1).max() < 1e-9 and len(set(match)) == len(match)
        assert np.allclose(got["cell"], want["cell"][match], atol=1e-9)
    # the body's first row on the 24-gon moved half a spacing in: between its edges' offset
    # (the apothem less dp/2) and its vertices' (R less dp/2 / cos(pi/24))
    inner = got["x"][:, got["body"] == 1]
    r = np.hypot(inner[0] - 0.5, inner[1] - 0.35)
    first = r[r > 0.1]
    assert 0.15 * math.cos(math.pi / 24) - 0.025 - 1e-9 <= first.min()
    assert abs(first.max() - (0.15 - 0.025 / math.cos(math.pi / 24))) < 1e-9


def test_two_outlines_of_a_2d_mesh_that_meet_at_a_vertex_are_one_line(tmp_path):
    path = _outline_mesh(tmp_path / "bow.vtk", [[[0.2, 0.2], [0.4, 0.2], [0.3, 0.3]], [[0.3, 0.3], [0.4, 0.4], [0.2, 0.4]]])
    case = validate({"dim": 2, "dp": 0.05, "time": {"end": 0.1}, "model": {"name": "classic"},
                     "tank": {"min": [0.0, 0.0], "max": [1.0, 1.0]}, "fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.1]}],
                     "walls": [{"mesh": path}]})
    with pytest.raises(CaseError, match=r"walls\[0\]\.mesh: two outlines meet at vertex \(0\.3, 0\.3\)"):
        geometry.build(case)


def test_a_2d_wall_mesh_thinner_than_dp_everywhere_is_one_line(tmp_path):
    path = _outline_mesh(tmp_path / "fin.vtk", [[[0.4, 0.5], [0.4, 0.52], [0.6, 0.52], [0.6, 0.5]]])
    case = validate({"dim": 2, "dp": 0.05, "time": {"end": 0.1}, "model": {"name": "classic"},
                     "tank": {"min": [0.0, 0.0], "max": [1.0, 1.0]}, "fluid": [{"min": [0.0, 0.0], "max": [1.0, 0.1]}],
                     "walls": [{"mesh": path}]})
    with pytest.raises(CaseError, match=r"walls\[0\]\.mesh: thinner than dp = 0\.05 everywhere"):
        geometry.build(case)
