"""Particles from the case geometry: fluid blocks, tank walls, box obstacles, 2D polygons.

Fluid particles sit on a lattice of spacing dp, dp/2 inside the block faces. Walls come in two
kinds, after the model:

* wall particles (classic model): ``layers`` deep behind the wall surface (the tank's inner
  faces, an obstacle's faces), on a lattice fitted to each box (``fitted_lattice``: a whole
  number of spacings of about dp across it), so that every face is half a spacing beyond its
  outer layer; a 2D polygon's in rows along its outline (``polygon_particles``), the outline
  half a spacing beyond the first, and a 2D mesh's outlines the same way; a 3D mesh's on the
  fluid's lattice; each point carries its
  cell's volume over dp^dim (``cell``), which scales its pseudo-mass;
* boundary elements (WCSPH-BI): the wall surface cut into segments (2D) or rectangular faces
  (3D) of size about ``boundaryElementSize`` (a length in 2D, an area in 3D; default dp or dp^2), each with its centre ``x``, size
  ``elementSize`` (length or area) and unit normal ``n``.

**Normal convention.** ``n`` points out of the fluid, into the wall: (0, -1) on a tank floor,
(0, 1) on the top face of an obstacle box. This is the outward normal of the fluid domain in
the boundary integrals of the WCSPH-BI spec (e.g. the wall part of grad p is
sum_b (p_i + p_b) n_b W_ib S_b, which cancels the bulk sum for a constant pressure only with
this orientation). A polygon wall has the fluid on the left of its direction of travel.

The last axis is vertical.
"""
import math
import os
from pathlib import Path

import numpy as np

from ..boundaries.floating import holds_fluid
from ..errors import CaseError
from ..io.expressions import evaluate
from ..io.readers import GeometryError, face_elements, inside, read_points, read_surface, surface_distance
from ..physics.kernels import SUPPORT, smoothing_length


def spacings(a, b, dp):
    """How many whole spacings of dp the interval [a, b] holds (``lattice``'s count per axis)."""
    return int(math.floor((b - a) / dp + 1e-6))


def lattice(lo, hi, dp):
    """Points lo + dp/2 + k dp inside the box [lo, hi], as a (dim, N) array."""
    axes = []
    for a, b in zip(lo, hi):
        n = spacings(a, b, dp)
        axes.append(a + dp * (0.5 + np.arange(n)))
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh]) if axes else np.zeros((0, 0))


def boundary_kind(case):
    """'particles' or 'elements', after the case's wall model (``model.BCType``)."""
    from ..physics.registry import SLOTS

    return SLOTS["walls"].choices[case["model"]["BCType"]].boundary


def element_size(case):
    """The edge length of the boundary elements: ``boundaryElementSize`` is a length in 2D
    and an area in 3D (the spec: "length or area"; TNL-SPH passes dp^2 in 3D); dp when 0."""
    s = case["model"]["boundaryElementSize"]
    if s <= 0:
        return case["dp"]
    return s if case["dim"] == 2 else math.sqrt(s)


def periodic_axes(case):
    """A flag per axis (three, z False in 2D): the axes along which the domain repeats."""
    d = case["domain"]
    flags = list(d["periodic"]) if d is not None and d["periodic"] is not None else [False] * case["dim"]
    return tuple(flags + [False] * (3 - len(flags)))


def periodic_box(case):
    """(lo, hi) of the repeating box: ``domain.min/max`` when given, else the tank's."""
    d = case["domain"]
    box = d if d is not None and d["min"] is not None else case["tank"]
    return np.asarray(box["min"], dtype=float), np.asarray(box["max"], dtype=float)


def wall_layers(case):
    layers = case["model"]["wall_layers"]
    if layers == 0 and case["model"]["wall_volume"] == "akinci":
        layers = 1  # the sampling Akinci's volume formula is made for
    elif layers == 0:
        layers = math.ceil(SUPPORT * smoothing_length(case) / case["dp"] - 1e-9)
    return layers


def _inside(x, lo, hi, tol=0.0):
    lo = np.asarray(lo)[:, None] + tol
    hi = np.asarray(hi)[:, None] - tol
    return np.all((x > lo) & (x < hi), axis=0)


def fitted_lattice(lo, hi, dp, below=None, above=None):
    """Points of a lattice fitted to the box [lo, hi]: along each axis round(L/dp) spacings
    (at least one) of s = L / n, points s/2 inside the faces, continued ``below[a]`` spacings
    below lo and ``above[a]`` above hi. Returns (points (dim, N), the cell's volume prod s).
    A wall sampled on it has its faces where the box has them, whatever dp; the plain
    ``lattice`` leaves a box that is not a whole number of dp thick up to dp short on its
    upper faces."""
    dim = len(lo)
    below = below if below is not None else [0] * dim
    above = above if above is not None else [0] * dim
    axes, cell = [], 1.0
    for a in range(dim):
        x, s = _fitted_axis(lo[a], hi[a], dp, below[a], above[a])
        axes.append(x)
        cell *= s
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh]), cell


def _fitted_axis(a, b, step, below=0, above=0):
    """The centres of [a, b] cut into round((b - a)/step) equal pieces (at least one),
    continued ``below`` pieces below a and ``above`` above b, and the pieces' width."""
    n = max(1, int(round((b - a) / step)))
    w = (b - a) / n
    return a + w * (0.5 + np.arange(-below, n + above)), w


def thin_obstacles(case):
    """A line for each obstacle box thinner than dp along an axis, for a model with wall
    particles: its lattice has one layer there, of less than a fluid particle's mass per
    spacing, and the fluid on either side meets a wall thinner than its kernel. And one for
    each closed polygon whose first row of wall particles leaves a stretch of its outline
    more than ``GAP`` dp from any of them: a tip or a fin thinner than dp, where the rows
    stop (``polygon_particles``) and the fluid can pass."""
    if boundary_kind(case) != "particles":
        return []
    dp, out = case["dp"], []
    for k, box in enumerate(case["obstacle"]):
        for a, (lo, hi) in enumerate(zip(box["min"], box["max"])):
            if hi - lo < dp * (1 - 1e-9):
                out.append(f"obstacle[{k}] is {(hi - lo) / dp:.2g} dp thick along axis {a}: one layer of wall "
                           "particles that thin does not keep the fluid out; use a smaller dp, or boundary "
                           "elements for thin walls (model.name = \"bi\")")
    for k, poly in enumerate(case["polygon"]):
        if poly["closed"]:
            bare = _bare_outline(poly["points"], dp)
            if bare > 0.0:
                out.append(f"polygon[{k}] has {bare:.3g} m of its outline more than {GAP:g} dp from its wall "
                           "particles (a tip or part thinner than dp, where the rows of wall particles stop): "
                           "the fluid can pass there; use a smaller dp, or boundary elements for thin walls "
                           "(model.name = \"bi\")")
    return out


#: a fluid box whose lattice of dp falls short of it by more than this fraction of its length
#: along an axis is named at the start (``short_blocks``)
SHORT = 0.01


def short_blocks(case, rounded_top=False):
    """A line for each fluid box and axis where the lattice of dp (``lattice``: whole spacings
    from the box's lower face) holds more than ``SHORT`` less than the box: a box L long
    holds floor(L / dp) spacings, so SPHERIC 2's 0.55 m deep reservoir at dp = 0.035 is
    0.525 m of water (15 spacings, 4.5 % short), and a dam break's flood is that column's.
    ``rounded_top``: the vertical is sampled by ``compressed_lattice`` (a summation density's
    column at rest), which rounds its layers to the nearest whole number and is not
    checked. A box with ``fill = "fitted"`` is sampled as drawn and is not named."""
    dp, dim, out = case["dp"], case["dim"], []
    for k, block in enumerate(case["fluid"]):
        if block["min"] is None or block["fill"] == "fitted":  # sampled as given, or fitted to the box
            continue
        for a, (lo, hi) in enumerate(zip(block["min"], block["max"])):
            if rounded_top and a == dim - 1:
                continue
            length = hi - lo
            n = spacings(lo, hi, dp)
            if n and length - n * dp > SHORT * length:
                fit = _fitted_axis(lo, hi, dp)[1]  # the spacing a fitted box would take
                out.append(f"fluid[{k}] is {length:g} m along axis {a} and holds {n} spacings of dp = {dp:g} m "
                           f"({n * dp:.4g} m of fluid, {100 * (1 - n * dp / length):.1f} % short); a dp that divides "
                           f"{length:g} m samples it whole (e.g. {fit:.4g} m), or fill = \"fitted\" the box as drawn")
    return out


#: a polygon's outline is bare where its nearest wall particle is further than this, in dp (the
#: first row stands half a spacing off it, its particles a spacing apart: 0.71 dp at most)
GAP = 1.5


def _bare_outline(points, dp):
    """The length of the closed outline ``points`` further than ``GAP`` dp from its first row
    of wall particles (sampled every dp/4; ``_clear_of`` finds the samples with no particle
    that near)."""
    pts = np.asarray(points, dtype=float)
    x, _ = polygon_particles(pts, dp, 1)
    ends = np.roll(pts, -1, axis=0)
    length = np.linalg.norm(ends - pts, axis=1)
    m = np.maximum(1, np.ceil(length / (0.25 * dp)).astype(int))
    s = np.concatenate([a + (b - a) * ((np.arange(n) + 0.5) / n)[:, None] for a, b, n in zip(pts, ends, m)]).T
    return float(np.repeat(length / m, m)[_clear_of(s, x, GAP * dp)].sum())


def tank_particles(tank, dp, layers, periodic=(False, False, False)):
    """The tank's walls, ``layers`` deep on a lattice fitted to the tank (``fitted_lattice``),
    and their cell volume; none across a periodic axis (the lattice there spans exactly the
    tank, so it joins up across the seam)."""
    lo = np.asarray(tank["min"], dtype=float)
    hi = np.asarray(tank["max"], dtype=float)
    dim = lo.size
    t = [0 if periodic[a] else layers for a in range(dim)]
    top = list(t)
    if tank["open_top"]:
        top[-1] = 0
    pts, cell = fitted_lattice(lo, hi, dp, t, top)
    interior_lo, interior_hi = lo.copy(), hi.copy()
    if tank["open_top"]:
        interior_hi[-1] = hi[-1] + dp  # no lid
    for a in range(dim):
        if periodic[a]:
            interior_lo[a], interior_hi[a] = -np.inf, np.inf
    return pts[:, ~_inside(pts, interior_lo, interior_hi)], cell


def _in_polygon(x, pts, margin):
    """Points of x (2, N) inside the closed polygon ``pts`` (M, 2) or within ``margin`` of its
    outline (even-odd rule, and the distance to each side), in chunks of x."""
    a, b = pts, np.roll(pts, -1, axis=0)
    inside = np.empty(x.shape[1], dtype=bool)
    step = max(1, 2 ** 22 // len(a))
    for s in range(0, x.shape[1], step):
        px, py = x[0, s:s + step][:, None], x[1, s:s + step][:, None]
        crosses = ((a[:, 1] > py) != (b[:, 1] > py)) & (
            px < a[:, 0] + (py - a[:, 1]) * (b[:, 0] - a[:, 0]) / np.where(b[:, 1] != a[:, 1], b[:, 1] - a[:, 1], 1.0))
        inside[s:s + step] = crosses.sum(axis=1) % 2 == 1
    return inside | (_outline_distance(x, pts) < margin) if margin > 0 else inside


def obstacle_particles(box, dp, layers):
    """A solid box, sampled ``layers`` deep from its faces on a lattice fitted to it
    (``fitted_lattice``; its core is never reached), and the lattice's cell volume."""
    lo = np.asarray(box["min"], dtype=float)
    hi = np.asarray(box["max"], dtype=float)
    pts, cell = fitted_lattice(lo, hi, dp)
    return pts[:, ~_inside(pts, lo + layers * dp, hi - layers * dp)], cell


def polygon_particles(points, dp, layers):
    """Wall particles of a closed polygon, in rows along its outline on its solid side: row k
    on the curve (k + 1/2) dp from the outline, so that the outline lies half a spacing
    beyond the first row wherever it runs, as a box's faces do (``fitted_lattice``). Each
    row is cut at its corners (where the outline turns by more than ``CORNER`` towards the
    solid) into stretches of round(length / dp) equal pieces, a particle at each corner and
    between the pieces; a row without corners is cut evenly all round, a stretch that ends
    where the row is left out (the solid thinner than the row's depth) ends half a piece
    from there. A rectangle on the fluid's lattice gets the obstacle box's particles. The
    fluid is on the left of the direction of travel, so the solid side is the inside of a
    clockwise outline (a body) and the outside of a counter-clockwise one (a container).
    Returns (points (2, N), each point's cell: its pieces' mean length times dp)."""
    pts = np.asarray(points, dtype=float)
    pts = pts[np.linalg.norm(pts - np.roll(pts, 1, axis=0), axis=1) > 1e-12 * max(1.0, np.ptp(pts))]
    body = not holds_fluid(pts)
    xs, cells = [], []
    for k in range(layers):
        x, cell = _row(pts, (k + 0.5) * dp, dp, body)
        keep = _sparse(x, 0.5 * dp)  # a row that meets itself (the solid 2d thick) once
        xs.append(x[:, keep])
        cells.append(cell[keep])
    return np.concatenate(xs, axis=1), np.concatenate(cells)


#: a row of wall particles has a corner where its polygon turns by more than this towards the
#: solid [rad]
CORNER = math.radians(15.0)


def _row(pts, d, dp, body):
    """The particles of the row at distance d from the closed outline ``pts`` (M, 2) on its
    right (the solid side) and their cells: the edges moved out by d, joined by their
    intersection where the outline turns right (a corner if by more than ``CORNER``) and by
    an arc about the vertex where it turns left; the curve sampled every dp/8 at most (an
    arc every dp/64); the
    stretches nearer the outline than d (where the solid is thinner than 2d) left out."""
    e = np.roll(pts, -1, axis=0) - pts
    t = e / np.linalg.norm(e, axis=1)[:, None]
    n = np.stack([t[:, 1], -t[:, 0]], axis=1)  # right of the direction of travel
    joints, sharp = [], []
    for i in range(len(pts)):
        n0, n1 = n[i - 1], n[i]
        turn = t[i - 1, 0] * t[i, 1] - t[i - 1, 1] * t[i, 0]
        angle = math.atan2(turn, t[i - 1] @ t[i])  # > 0 a left turn, < 0 a right one
        if angle < 0.0:  # the moved edges cross on the solid side
            joints.append(pts[i] + d * (n0 + n1) / (1.0 + n0 @ n1))
            sharp.append(angle < -CORNER)
        else:
            a0 = math.atan2(n0[1], n0[0])
            m = max(1, int(math.ceil(angle * d / (dp / 64))))  # chords within 1e-4 dp of the arc
            a = a0 + angle * np.arange(m + 1) / m
            joints.extend(pts[i] + d * np.stack([np.cos(a), np.sin(a)], axis=1))
            sharp.extend([False] * (m + 1))
    curve = np.array(joints + [joints[0]])
    dense, corner = [curve[:1]], [np.array(sharp[:1])]
    for j, (a, b) in enumerate(zip(curve[:-1], curve[1:])):
        m = max(1, int(math.ceil(np.linalg.norm(b - a) / (dp / 8))))
        dense.append(a + (b - a) * (np.arange(1, m + 1) / m)[:, None])
        corner.append(np.r_[np.zeros(m - 1, dtype=bool), sharp[(j + 1) % len(sharp)]])
    dense, corner = np.concatenate(dense).T[:, :-1], np.concatenate(corner)[:-1]  # closed: the last is the first
    ok = np.abs(_outline_distance(dense, pts) - d) < 1e-3 * dp
    ok &= _in_polygon(dense, pts, 0.0) == body
    if ok.all() and not corner.any():  # a closed row without corners, cut evenly all round
        stretches = [(np.concatenate([dense, dense[:, :1]], axis=1), False, False)]
    else:  # stretches from a corner or a cut to the next corner or cut
        first = int(np.argmax(~ok | corner))
        dense, ok, corner = (np.roll(a, -first, axis=-1) for a in (dense, ok, corner))
        dense, ok, corner = np.c_[dense, dense[:, :1]], np.r_[ok, ok[0]], np.r_[corner, corner[0]]
        stretches, run = [], None
        for i in range(dense.shape[1]):
            if not ok[i]:
                if run is not None and len(run) > 1:
                    stretches.append((dense[:, run], bool(corner[run[0]]), False))
                run = None
            elif run is None:
                run = [i]
            else:
                run.append(i)
                if corner[i]:
                    stretches.append((dense[:, run], bool(corner[run[0]]), True))
                    run = [i]
    xs, cells, ends = [], [], []
    for line, from_corner, to_corner in stretches:
        at = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=1), axis=0))])
        if at[-1] < 0.25 * dp:  # (between two corners: the next stretch starts about where this one does)
            continue
        # particles at a0 + j s, j < m, the last s (to a corner: the next stretch's) or s/2 from the end
        a0, b = (0.0 if from_corner else 0.5), (1.0 if to_corner else 0.5)
        m = max(1, int(round(at[-1] / dp - a0 - b + 1)))
        s = at[-1] / (m - 1 + a0 + b)
        w = s * (a0 + np.arange(m))
        xs.append(np.stack([np.interp(w, at, line[0]), np.interp(w, at, line[1])]))
        cells.append(np.full(m, s * dp))
        ends.append((from_corner, to_corner, s))
    if not xs:
        return np.zeros((2, 0)), np.zeros(0)
    for j, (from_corner, _, s) in enumerate(ends):  # a corner's cell: half a piece on either side
        if from_corner and ends[j - 1][1]:
            cells[j][0] = 0.5 * (s + ends[j - 1][2]) * dp
    return np.concatenate(xs, axis=1), np.concatenate(cells)


def _sparse(x, r):
    """Which points of x (dim, N) to keep so that no two kept ones are nearer than r, in
    order: the first of each cluster (only the points with another within r are visited)."""
    keep = np.ones(x.shape[1], dtype=bool)
    crowded = np.flatnonzero(~_clear_of(x, x, r, same=True))
    for n, i in enumerate(crowded):
        kept = crowded[:n][keep[crowded[:n]]]
        if np.any(np.sum((x[:, kept] - x[:, i:i + 1]) ** 2, axis=0) < r * r):
            keep[i] = False
    return keep


def _outline_distance(x, pts, closed=True):
    """The distance of each point of x (2, N) to the outline ``pts`` (M, 2), closed or open
    (a polyline), in chunks of x."""
    a, b = (pts, np.roll(pts, -1, axis=0)) if closed else (pts[:-1], pts[1:])
    ab = b - a
    ab2 = np.maximum((ab ** 2).sum(axis=1), 1e-300)
    out = np.empty(x.shape[1])
    step = max(1, 2 ** 22 // len(a))
    for s in range(0, x.shape[1], step):
        px, py = x[0, s:s + step][:, None], x[1, s:s + step][:, None]
        t = np.clip(((px - a[:, 0]) * ab[:, 0] + (py - a[:, 1]) * ab[:, 1]) / ab2, 0, 1)
        out[s:s + step] = np.sqrt(((px - a[:, 0] - t * ab[:, 0]) ** 2 + (py - a[:, 1] - t * ab[:, 1]) ** 2).min(axis=1))
    return out


def _tiles(lo, hi, size):
    """Centres and sizes of a box face [lo, hi] (one axis flat) cut into near-square tiles of
    edge about ``size``."""
    axes, widths = [], []
    for a, b in zip(lo, hi):
        if b == a:
            axes.append(np.array([a]))
            widths.append(1.0)
            continue
        x, w = _fitted_axis(a, b, size)
        axes.append(x)
        widths.append(w)
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh]), float(np.prod(widths))


def box_elements(box, size, fluid_inside, skip_top=False, periodic=(False, False, False), seams=None):
    """Boundary elements on the faces of ``box``: its inside is fluid (a tank) or solid (an
    obstacle). No faces across a periodic axis: none at all for a tank, and for an obstacle
    none that lie on the periodic box's sides (``seams``: its (lo, hi)), where the obstacle
    continues through the seam. Returns x (dim, N), n (dim, N), S (N,)."""
    lo = np.asarray(box["min"], dtype=float)
    hi = np.asarray(box["max"], dtype=float)
    dim = lo.size
    xs, ns, ss = [], [], []
    for a in range(dim):
        for side, sign in ((lo, -1.0), (hi, 1.0)):
            if skip_top and a == dim - 1 and sign > 0:
                continue
            if periodic[a] and (seams is None or any(abs(side[a] - c[a]) < 1e-9 * size for c in seams)):
                continue
            f_lo, f_hi = lo.copy(), hi.copy()
            f_lo[a] = f_hi[a] = side[a]
            x, area = _tiles(f_lo, f_hi, size)
            n = np.zeros_like(x)
            n[a] = sign if fluid_inside else -sign  # out of the fluid
            xs.append(x)
            ns.append(n)
            ss.append(np.full(x.shape[1], area))
    return np.concatenate(xs, axis=1), np.concatenate(ns, axis=1), np.concatenate(ss)


def polygon_elements(points, closed, size):
    """Segments of a 2D polyline, fluid on the left of the direction of travel, so that
    n = (dy, -dx)/|d| points out of the fluid."""
    pts = np.asarray(points, dtype=float)
    if closed:
        pts = np.vstack([pts, pts[:1]])
    xs, ns, ss = [], [], []
    for p, q in zip(pts[:-1], pts[1:]):
        d = q - p
        length = float(np.hypot(*d))
        if length == 0:
            continue
        k = max(1, int(round(length / size)))
        t = (0.5 + np.arange(k)) / k
        xs.append(p[:, None] + d[:, None] * t)
        ns.append(np.repeat(np.array([d[1], -d[0]])[:, None] / length, k, axis=1))
        ss.append(np.full(k, length / k))
    return np.concatenate(xs, axis=1), np.concatenate(ns, axis=1), np.concatenate(ss)


def boundary_elements(case, size):
    """All boundary elements of ``case``: x, n, elementSize, and each one's body index (in
    the order of ``wall_sources``)."""
    dim = case["dim"]
    parts = []
    if case["tank"] is not None:
        parts.append(box_elements(case["tank"], size, True, case["tank"]["open_top"], periodic_axes(case)))
    seams = periodic_box(case) if any(periodic_axes(case)) else None
    for box in case["obstacle"]:
        parts.append(box_elements(box, size, False, periodic=periodic_axes(case), seams=seams))
    for poly in case["polygon"]:
        parts.append(polygon_elements(poly["points"], poly["closed"], size))
    for k, w in enumerate(case["walls"]):
        parts.append(_file_elements(case, k, w, size))
    if not parts:
        return np.zeros((dim, 0)), np.zeros((dim, 0)), np.zeros(0), np.zeros(0, dtype=np.int64)
    body = np.concatenate([np.full(p[0].shape[1], b, dtype=np.int64) for b, p in enumerate(parts)])
    return tuple(np.concatenate(p, axis=-1) for p in zip(*parts)) + (body,)


def _path(case, name):
    """A file named in a case, relative to the case file's directory."""
    src = Path(case["_source"])
    base = src.parent if src.suffix == ".toml" else Path.cwd()
    return base / name


def _read(case, key, fn, *args):
    try:
        return fn(*args)
    except GeometryError as e:
        raise CaseError(f"{case['_source']}: {key}: {e}") from None


def _file_elements(case, k, w, size):
    """Boundary elements of ``walls[k]``: a point file with normals and sizes, or the faces of a
    closed mesh (``io.readers``)."""
    key, dim = f"walls[{k}]", case["dim"]
    if w["file"]:
        pts = _read(case, key + ".file", read_points, _path(case, w["file"]), dim)
        missing = [f for f in ("n", "elementSize") if f not in pts]
        if missing:
            raise CaseError(f"{case['_source']}: {key}.file: boundary elements need the point fields "
                            f"{' and '.join(missing)} (normals out of the fluid and sizes); this file has "
                            f"{', '.join(sorted(pts)) or 'only points'}")
        return pts["x"], pts["n"], pts["elementSize"]
    verts, faces = _read(case, key + ".mesh", read_surface, _path(case, w["mesh"]), dim)
    return face_elements(verts, faces, size, w["fluid_side"] == "inside")


def _file_particles(case, k, w, dp, layers):
    """Wall particles of ``walls[k]`` and their cells (one volume for all, or one each): the
    points of a point file; a 2D mesh's closed outlines in rows along them, as a polygon's
    (``polygon_particles``); a 3D mesh's lattice points within ``layers`` dp of it on its wall
    side (inside a body, outside a tank)."""
    key, dim = f"walls[{k}]", case["dim"]
    if w["file"]:
        return _read(case, key + ".file", read_points, _path(case, w["file"]), dim)["x"], dp ** dim
    verts, faces = _read(case, key + ".mesh", read_surface, _path(case, w["mesh"]), dim)
    if dim == 2:
        # an outward-oriented outline has the mesh's inside on its left: the fluid's side
        # for a tank, the solid's (travelled the other way) for a body
        loops = [_from_first(loop if w["fluid_side"] == "inside" else loop[::-1])
                 for loop in _read(case, key + ".mesh", outline_loops, verts, faces)]
        rows = [polygon_particles(loop, dp, layers) for loop in loops]
        x = np.concatenate([x for x, _ in rows], axis=1)
        if x.shape[1] == 0:
            raise CaseError(f"{case['_source']}: {key}.mesh: thinner than dp = {dp} everywhere, it gets no wall "
                            "particle; use a smaller dp, or boundary elements for thin walls (model.name = \"bi\")")
        return x, np.concatenate([c for _, c in rows])
    t = layers * dp
    pts = lattice(verts.min(axis=1) - t, verts.max(axis=1) + t, dp)
    within = surface_distance(pts, verts, faces, dp) < t
    pts = pts[:, within]
    ins = inside(pts, verts, faces)
    return pts[:, ~ins if w["fluid_side"] == "inside" else ins], dp ** dim


def _from_first(loop):
    """``loop`` (M, 2) started at its vertex of least x (then y): a row cut evenly all round
    (``polygon_particles``) starts where its outline does, so a mesh's particles do not move
    with the order its file lists the segments in."""
    k = min(range(len(loop)), key=lambda i: (loop[i, 0], loop[i, 1]))
    return np.roll(loop, -k, axis=0)


def outline_loops(verts, segments):
    """The closed outlines of a 2D mesh (``read_surface``: closed, oriented segments), each
    as its vertices (M, 2) in the segments' direction of travel. A vertex where two outlines
    touch (two segments leave it) is a GeometryError naming it."""
    nxt = {}
    for a, b in segments:
        if int(a) in nxt:
            x = verts[:, int(a)]
            raise GeometryError(f"two outlines meet at vertex ({x[0]:g}, {x[1]:g}); "
                                "give each outline its own vertices")
        nxt[int(a)] = int(b)
    loops, seen = [], set()
    for start in nxt:
        if start in seen:
            continue
        loop, v = [], start
        while v not in seen:
            seen.add(v)
            loop.append(v)
            v = nxt[v]
        loops.append(verts[:, loop].T.copy())
    return loops


def _file_fluid(case, k, block, dp):
    """(x, v or None, p or None) of a fluid block given by a point file or a surface to fill
    (lattice points inside it, at least dp/2 from it)."""
    key, dim = f"fluid[{k}]", case["dim"]
    if block["file"]:
        pts = _read(case, key + ".file", read_points, _path(case, block["file"]), dim)
        return pts["x"], pts.get("v"), pts.get("p")
    verts, faces = _read(case, key + ".surface", read_surface, _path(case, block["surface"]), dim)
    pts = lattice(verts.min(axis=1), verts.max(axis=1), dp)
    pts = pts[:, inside(pts, verts, faces)]
    pts = pts[:, surface_distance(pts, verts, faces, dp) > 0.5 * dp * (1 - 1e-6)]
    return pts, None, None


def _clear_of(x, pts, r, same=False):
    """Which points of x (dim, N) have no point of ``pts`` (dim, M) within r: the points hashed
    into cells of edge r, each point of x tested against those in the 3^dim cells about its
    own. ``same``: ``pts`` is x itself, and a point is not tested against itself."""
    keep = np.ones(x.shape[1], dtype=bool)
    if not pts.shape[1] or not x.shape[1]:
        return keep
    lo = np.minimum(x.min(axis=1), pts.min(axis=1)) - 2 * r
    span = np.floor((np.maximum(x.max(axis=1), pts.max(axis=1)) - lo) / r).astype(np.int64) + 3
    stride = np.concatenate([[1], np.cumprod(span[:-1])])

    def key(c):
        return (c * stride[:, None]).sum(axis=0)

    pk = key(np.floor((pts - lo[:, None]) / r).astype(np.int64))
    order = np.argsort(pk, kind="stable")
    pk, pts = pk[order], pts[:, order]
    cx = np.floor((x - lo[:, None]) / r).astype(np.int64)
    for off in np.stack(np.meshgrid(*[[-1, 0, 1]] * x.shape[0], indexing="ij")).reshape(x.shape[0], -1).T:
        k = key(cx + off[:, None])
        a, b = np.searchsorted(pk, k, "left"), np.searchsorted(pk, k, "right")
        for n in range(int(np.max(b - a))):  # the n-th point of each cell, where it has one
            has = a + n < b
            if same:
                has[has] = order[a[has] + n] != np.flatnonzero(has)
            j = a[has] + n
            keep[np.flatnonzero(has)[np.sum((x[:, has] - pts[:, j]) ** 2, axis=0) < r * r]] = False
    return keep


def _wall_files(case):
    """[(walls table, its points (dim, M) or None, its mesh (vertices, faces) or None)] of
    the case's ``[[walls]]``, each file read once for every fluid block ``_carved`` cuts."""
    out = []
    for k, w in enumerate(case["walls"]):
        key = f"walls[{k}]"
        pts = (_read(case, key + ".file", read_points, _path(case, w["file"]), case["dim"])["x"]
               if w.get("file") else None)
        mesh = _read(case, key + ".mesh", read_surface, _path(case, w["mesh"]), case["dim"]) if w.get("mesh") else None
        out.append((w, pts, mesh))
    return out


def _carved(case, x, dp, wall_files):
    """The lattice points x (dim, N) of a fluid box or surface fill that the walls leave to
    the fluid, each at least dp/2 from them: outside the obstacle boxes; outside a closed
    polygon that is a body (clockwise), inside one that is a container (counter-clockwise),
    off an open one; outside a closed ``[[walls]]`` mesh with ``fluid_side = "outside"``,
    inside one with ``"inside"`` (only the points within a mesh's box grown by dp/2 are
    tested); off a ``[[walls]]`` point file's points (it has no solid side). ``wall_files``:
    ``_wall_files(case)``."""
    for box in case["obstacle"]:
        x = x[:, ~_inside(x, np.asarray(box["min"]) - 0.5 * dp, np.asarray(box["max"]) + 0.5 * dp, 1e-6 * dp)]
    for poly in case["polygon"]:
        pts = np.asarray(poly["points"], dtype=float)
        if not poly["closed"]:  # a polyline has no solid side: none within dp/2 of it
            x = x[:, _outline_distance(x, pts, closed=False) >= 0.5 * dp * (1 - 1e-6)]
        elif holds_fluid(pts):
            x = x[:, _in_polygon(x, pts, 0.0) & (_outline_distance(x, pts) >= 0.5 * dp * (1 - 1e-6))]
        else:
            x = x[:, ~_in_polygon(x, pts, 0.5 * dp * (1 - 1e-6))]
    for w, pts, mesh in wall_files:
        if pts is not None and x.shape[1]:  # points without a solid side: none within dp/2 of one
            x = x[:, _clear_of(x, pts, 0.5 * dp * (1 - 1e-6))]
        if mesh is None or x.shape[1] == 0:
            continue
        verts, faces = mesh
        lo, hi = verts.min(axis=1) - 0.5 * dp, verts.max(axis=1) + 0.5 * dp
        near = np.all((x >= lo[:, None]) & (x <= hi[:, None]), axis=0)
        keep = ~near if w["fluid_side"] == "outside" else np.zeros(x.shape[1], dtype=bool)
        y = x[:, near]
        if y.shape[1]:
            ins = inside(y, verts, faces)
            clear = surface_distance(y, verts, faces, dp) >= 0.5 * dp * (1 - 1e-6)
            keep[near] = clear & (ins if w["fluid_side"] == "inside" else ~ins)
        x = x[:, keep]
    return x


def wall_sources(case):
    """(name, motion, key) of every wall source: the tank, the obstacles, the polygons; a
    body each (``motion.Bodies``)."""
    from .config import _wall_sources

    return [(b["name"], b["motion"], key) for key, b in _wall_sources(case)]


#: bytes per particle a run may hold, fluid and wall: an upper bound counted from the fields
#: (about 30 values of the working dtype with the integrator's copies, the sort's spare
#: copies of the sorted fields, two int64), not a measurement
BYTES_PER_PARTICLE = {"float32": 400, "float64": 800}


def estimate(case):
    """(fluid particles, wall particles or elements, bytes) of ``case``, from its boxes alone,
    before anything is allocated: lattices of dp over the fluid blocks, tank faces times
    wall layers (classic) or faces / element size (WCSPH-BI)."""
    dp, dim = case["dp"], case["dim"]
    n_fluid = sum(math.prod(max(0.0, (b - a) / dp) for a, b in zip(blk["min"], blk["max"]))
                  for blk in case["fluid"] if blk["min"] is not None)  # files are counted when read
    boxes = ([case["tank"]] if case["tank"] is not None else []) + list(case["obstacle"])
    n_wall = 0.0
    for box in boxes:
        ext = [b - a for a, b in zip(box["min"], box["max"])]
        if boundary_kind(case) == "elements":
            size = element_size(case)
            area = 2 * (ext[0] + ext[1]) if dim == 2 else 2 * (ext[0] * ext[1] + ext[1] * ext[2] + ext[0] * ext[2])
            n_wall += area / (size if dim == 2 else size * size)
        else:  # the wall layers are cut from a lattice over the box grown by their thickness
            grown = 2 * wall_layers(case) * dp
            n_wall += math.prod((e + grown) / dp for e in ext)
    total = (n_fluid + n_wall) * BYTES_PER_PARTICLE[case["precision"]]
    return n_fluid, n_wall, total


def check_size(case):
    """A clear error, before any allocation, for a case that would not fit in this machine's
    memory (DualSPHysics and TNL-SPH fail deep inside an allocation instead)."""
    n_fluid, n_wall, need = estimate(case)
    try:
        have = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return
    if need > 0.8 * have:
        raise CaseError(f"{case['_source']}: dp: {case['dp']:g} m makes about {n_fluid:.3g} fluid and {n_wall:.3g} "
                        f"wall particles, about {need / 2**30:.3g} GiB; this machine has {have / 2**30:.3g} GiB. "
                        "Use a larger dp (particle count goes as dp^-dim)")


def compressed_lattice(lo, hi, dp, column):
    """The points of ``lattice(lo, hi, dp)`` for a column at rest whose density grows with
    depth as ``column(depth)`` = rho / rho0 (>= 1): a summation density is the particles'
    number density, so the layers sit closer by that ratio, and the block holds the mass of
    a compressed column up to its top ``hi[-1]`` (the water level stays where the case puts
    it; a lattice of spacing dp settles lower by the column's mean compression, 1.6 % of its
    depth at c0 = 50 m/s and 8 m). The layers are spaced in the material coordinate s, ds =
    column(top - y) dy, counted from the bottom, so the lowest layer keeps dp / 2 from it; the
    number of layers is the material height / dp rounded to the nearest (the top layer within
    dp / 2 of where a lattice filling the column exactly would put it)."""
    a, b = float(lo[-1]), float(hi[-1])
    y = np.linspace(a, b, max(int(math.ceil((b - a) / dp)) * 16, 2) + 1)
    r = np.asarray(column(b - y), dtype=float)
    s = np.concatenate([[a], a + np.cumsum(0.5 * (r[1:] + r[:-1]) * np.diff(y))])
    layers = int(round((s[-1] - a) / dp))
    x = lattice(lo, list(hi[:-1]) + [a + layers * dp], dp)
    above = x[-1] > s[-1]  # beyond the top (half a layer at most): at the surface's density
    x[-1] = np.where(above, b + (x[-1] - s[-1]) / r[-1], np.interp(x[-1], s, y))
    return x


def build(case, column=None):
    """The fluid (a dict: ``x``, ``v``, ``top``, the top of each particle's block, and ``p``,
    its initial pressure where the block gives one, else NaN), the walls (a dict: ``x``, ``body``, and for wall particles
    ``cell``, for boundary elements ``n`` and ``elementSize``), and the domain box of ``case``. ``column``: depth -> rho / rho0
    of a column at rest, for a summation-density model (``compressed_lattice``); the boxes of
    fluid without a ``pressure`` are sampled compressed by it."""
    src, dp, dim = case["_source"], case["dp"], case["dim"]
    if boundary_kind(case) == "elements":
        x, n, size, body = boundary_elements(case, element_size(case))
        wall_set = {"x": x, "n": n, "elementSize": size, "body": body}
    else:
        for k, poly in enumerate(case["polygon"]):
            if not poly["closed"]:
                raise CaseError(f"{src}: polygon[{k}].closed: an open polygon has no solid side for wall particles; "
                                "close it, or use boundary elements (model.BCType = \"BIConsistent_numeric\", or "
                                "model.name = \"bi\")")
        layers = wall_layers(case)
        sources = []  # (points, the volume of their cells: one for all or one each) of each wall source
        if case["tank"] is not None:
            sources.append(tank_particles(case["tank"], dp, layers, periodic_axes(case)))
        for box in case["obstacle"]:
            sources.append(obstacle_particles(box, dp, layers))
        for k, poly in enumerate(case["polygon"]):
            sources.append(polygon_particles(poly["points"], dp, layers))
            if sources[-1][0].shape[1] == 0:
                raise CaseError(f"{src}: polygon[{k}]: thinner than dp = {dp} everywhere, it gets no wall "
                                "particle; use a smaller dp, or boundary elements for thin walls (model.name = \"bi\")")
        for k, w in enumerate(case["walls"]):
            sources.append(_file_particles(case, k, w, dp, layers))
        parts = [x for x, _ in sources]
        wall_set = {"x": np.concatenate(parts, axis=1) if parts else np.zeros((dim, 0)),
                    "body": np.concatenate([np.full(p.shape[1], b, dtype=np.int64) for b, p in enumerate(parts)])
                    if parts else np.zeros(0, dtype=np.int64),
                    "cell": np.concatenate([np.broadcast_to(np.asarray(c, dtype=float) / dp ** dim, x.shape[1:])
                                            for x, c in sources])
                    if parts else np.zeros(0)}
    walls = wall_set["x"]

    xs, vs, tops, ps, cells = [], [], [], [], []
    wall_files = _wall_files(case)
    for k, block in enumerate(case["fluid"]):
        if block["min"] is None:  # a point file or a surface to fill
            x, v_file, p_file = _file_fluid(case, k, block, dp)
            if x.shape[1] == 0:
                raise CaseError(f"{src}: fluid[{k}]: the surface encloses no lattice point of dp = {dp}")
            if block["surface"]:  # a lattice, as a box's: cut as a box is (a point file is taken as given)
                x = _carved(case, x, dp, wall_files)
            xs.append(x)
            cells.append(np.ones(x.shape[1]))
            vs.append(np.stack([evaluate(str(c), x) for c in block["velocity"]]) if block["velocity"] is not None
                      else (v_file if v_file is not None else np.zeros_like(x)))
            tops.append(np.full(x.shape[1], x[-1].max() + 0.5 * dp))
            ps.append(evaluate(str(block["pressure"]), x) if block["pressure"] is not None
                      else (p_file if p_file is not None else np.full(x.shape[1], np.nan)))
            continue
        if case["tank"] is not None:
            t = case["tank"]
            top = math.inf if t["open_top"] else t["max"][-1]
            for a in range(dim):
                hi_a = top if a == dim - 1 else t["max"][a]
                if block["min"][a] < t["min"][a] - 1e-9 * dp or block["max"][a] > hi_a + 1e-9 * dp:
                    raise CaseError(f"{src}: fluid[{k}]: block reaches into the tank wall on axis {a} "
                                    f"(tank interior is {t['min']} .. {t['max']})")
        cell = 1.0  # the particles' cell over dp^dim
        top = block["max"][-1]  # the surface the block's hydrostatic start counts its depth from
        if block["fill"] == "fitted":
            if column is not None and block["pressure"] is None:
                raise CaseError(f"{src}: fluid[{k}].fill: \"fitted\" does not take a summation density's column "
                                "at rest, which is sampled compressed, layer by layer: use fill = \"lattice\", a "
                                "continuity density (model.density = \"continuity\") or physics.gravity_ramp_time")
            x, cell = fitted_lattice(block["min"], block["max"], dp)
            cell /= dp ** dim
        elif column is not None and block["pressure"] is None:
            x = compressed_lattice(block["min"], block["max"], dp, column)
        else:  # whole spacings from min: the water ends where they do (``short_blocks``)
            x = lattice(block["min"], block["max"], dp)
            top = block["min"][-1] + spacings(block["min"][-1], top, dp) * dp
        if x.shape[1] == 0:
            raise CaseError(f"{src}: fluid[{k}]: block is thinner than dp = {dp}, it holds no particle")
        x = _carved(case, x, dp, wall_files)
        xs.append(x)
        cells.append(np.full(x.shape[1], cell))
        vs.append(np.stack([evaluate(str(c), x) for c in (block["velocity"] or [0.0] * dim)]))
        tops.append(np.full(x.shape[1], top))
        ps.append(evaluate(str(block["pressure"]), x) if block["pressure"] is not None
                  else np.full(x.shape[1], np.nan))
    fluid_x = np.concatenate(xs, axis=1)
    fluid_v = np.concatenate(vs, axis=1)
    if fluid_x.shape[1] == 0:
        if any(p["closed"] for p in case["polygon"]):
            raise CaseError(f"{src}: polygon: the obstacles and closed polygons leave no fluid particle (a polygon "
                            "holds its fluid on the left of its points: inside when they run counter-clockwise)")
        if any(w.get("mesh") for w in case["walls"]):
            raise CaseError(f"{src}: walls: the obstacles and wall meshes leave no fluid particle (a mesh holds "
                            "its fluid on its fluid_side: \"inside\" a tank, \"outside\" a body)")
        raise CaseError(f"{src}: obstacle: the obstacles cover all the fluid; no fluid particle is left")

    d = case["domain"]
    h = smoothing_length(case)
    periodic = periodic_axes(case)
    if d is not None and d["min"] is not None:
        lo, hi = np.asarray(d["min"]), np.asarray(d["max"])
        outside = ~np.all((fluid_x >= lo[:, None]) & (fluid_x <= hi[:, None]), axis=0)
        if outside.any():
            p = fluid_x[:, np.argmax(outside)]
            raise CaseError(f"{src}: fluid: {int(outside.sum())} fluid particles lie outside the domain "
                            f"{list(lo)} .. {list(hi)}, e.g. at {np.round(p, 6).tolist()}")
        if walls.shape[1]:
            w_out = ~np.all((walls >= lo[:, None]) & (walls <= hi[:, None]), axis=0)
            if w_out.any():
                raise CaseError(f"{src}: domain: {int(w_out.sum())} wall particles lie outside the domain; "
                                "enlarge domain or leave it out to have it computed")
    else:
        allx = np.concatenate([fluid_x, walls], axis=1)
        lo = allx.min(axis=1) - SUPPORT * h
        hi = allx.max(axis=1) + SUPPORT * h
        hi[-1] += hi[-1] - lo[-1]  # head room for splashes
    if any(periodic):
        p_lo, p_hi = periodic_box(case)
        for a in range(dim):
            if periodic[a]:
                lo[a], hi[a] = p_lo[a], p_hi[a]
                out = (fluid_x[a] < lo[a]) | (fluid_x[a] >= hi[a])
                if out.any():
                    raise CaseError(f"{src}: fluid: {int(out.sum())} fluid particles lie outside the periodic "
                                    f"box {lo[a]:g} .. {hi[a]:g} along axis {a}")
    fluid = {"x": fluid_x, "v": fluid_v, "top": np.concatenate(tops), "p": np.concatenate(ps),
             "cell": np.concatenate(cells)}
    return fluid, wall_set, lo, hi


def lattice_density_sum(kernel_w_np, dim, dp, h):
    """sum_j W(|x_i - x_j|) of a full lattice around one particle, for the mass that makes
    the summation density of the initial lattice equal rho0 exactly."""
    n = int(math.ceil(SUPPORT * h / dp)) + 1
    ax = np.arange(-n, n + 1) * dp
    r = np.sqrt(sum(m**2 for m in np.meshgrid(*([ax] * dim), indexing="ij")))
    return float(kernel_w_np(r).sum())
