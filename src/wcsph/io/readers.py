"""Geometry from files: point sets (CSV, or VTK and whatever else meshio reads) for fluid and
wall particles, and surface meshes (STL, OBJ, PLY, VTK... through meshio) for walls and for
fluid filling a closed surface.

* Point files: ``x, y[, z]`` and optional fields. In CSV the header names the columns
  (``x, y, z, vx, vy, vz, p, rho, nx, ny, nz, elementSize``); in VTK they are point data
  (``v``/``velocity``, ``p``/``pressure``, ``rho``/``density``, ``n``/``normals``,
  ``elementSize``/``S``), as TNL-SPH's case generators write them.
* Surface meshes: 3D triangles (quads are split) or 2D line segments. A mesh must be closed
  (every edge shared by exactly two faces, or two segments at every vertex in 2D) and
  consistently oriented (each shared edge traversed once each way); otherwise it is a case
  error naming the file and the first bad edge. Its orientation is made outward (positive
  enclosed volume) before use.
"""
import warnings
from pathlib import Path

import numpy as np

ALIASES = {"v": ("v", "velocity", "Velocity"), "p": ("p", "pressure", "Pressure"), "rho": ("rho", "density", "Density"),
           "n": ("n", "normals", "Normals", "normal"), "elementSize": ("elementSize", "S", "size", "area")}


class GeometryError(ValueError):
    """A geometry file that cannot be used; the message names the file and the problem."""


def read_points(path, dim):
    """{"x": (dim, N), and "v", "p", "rho", "n", "elementSize" where the file has them}."""
    path = Path(path)
    if not path.exists():
        raise GeometryError(f"{path}: no such file")
    if path.suffix.lower() == ".csv":
        return _read_csv(path, dim)
    import meshio

    try:
        mesh = meshio.read(path)
    except Exception as e:  # meshio raises many kinds for a file it cannot parse
        raise GeometryError(f"{path}: cannot read as a point set: {e}") from None
    x = np.asarray(mesh.points, dtype=float)[:, :dim].T.copy()
    out = {"x": x}
    for name, aliases in ALIASES.items():
        for a in aliases:
            if a in mesh.point_data:
                d = np.asarray(mesh.point_data[a], dtype=float)
                out[name] = d[:, :dim].T.copy() if d.ndim == 2 else d.ravel().copy()
                break
    return _checked(path, out)


def _read_csv(path, dim):
    try:
        with open(path, encoding="utf-8") as f:
            header = f.readline().strip().split(",")
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except (OSError, ValueError, UnicodeDecodeError) as e:
        raise GeometryError(f"{path}: cannot read as CSV with a header row: {e}") from None
    cols = {h.strip(): k for k, h in enumerate(header)}
    axes = "xyz"[:dim]
    missing = [a for a in axes if a not in cols]
    if missing:
        raise GeometryError(f"{path}: the header {header} lacks the column(s) {', '.join(missing)}")
    if data.shape[1] != len(header):
        raise GeometryError(f"{path}: {data.shape[1]} values per row under {len(header)} header names")
    out = {"x": np.stack([data[:, cols[a]] for a in axes])}
    for name, comps in (("v", ["v" + a for a in axes]), ("n", ["n" + a for a in axes])):
        if all(c in cols for c in comps):
            out[name] = np.stack([data[:, cols[c]] for c in comps])
    for name in ("p", "rho", "elementSize"):
        if name in cols:
            out[name] = data[:, cols[name]].copy()
    return _checked(path, out)


def _checked(path, out):
    if out["x"].shape[1] == 0:
        raise GeometryError(f"{path}: holds no point")
    for k, a in out.items():
        if not np.all(np.isfinite(a)):
            raise GeometryError(f"{path}: field {k!r} has values that are not finite numbers")
    if "n" in out:
        norm = np.linalg.norm(out["n"], axis=0)
        if np.any(norm == 0):
            raise GeometryError(f"{path}: {int(np.sum(norm == 0))} normals are zero")
        out["n"] = out["n"] / norm
    return out


def read_surface(path, dim):
    """(vertices (dim, V), faces (F, dim)): triangles in 3D, segments in 2D, closed and
    outward oriented (a ``GeometryError`` otherwise)."""
    import meshio

    path = Path(path)
    if not path.exists():
        raise GeometryError(f"{path}: no such file")
    try:
        with warnings.catch_warnings():  # meshio's binary-STL size probe overflows on ASCII files
            warnings.simplefilter("ignore", RuntimeWarning)
            mesh = meshio.read(path)
    except Exception as e:
        raise GeometryError(f"{path}: cannot read as a surface mesh: {e}") from None
    pts = np.asarray(mesh.points, dtype=float)[:, :dim]
    faces = []
    for block in mesh.cells:
        if dim == 3 and block.type == "triangle":
            faces.append(block.data)
        elif dim == 3 and block.type == "quad":
            q = block.data
            faces += [q[:, [0, 1, 2]], q[:, [0, 2, 3]]]
        elif dim == 2 and block.type == "line":
            faces.append(block.data)
    if not faces:
        kind = "triangles" if dim == 3 else "line segments"
        raise GeometryError(f"{path}: has no {kind} (cells: {', '.join(b.type for b in mesh.cells) or 'none'})")
    faces = np.concatenate(faces).astype(np.int64)
    pts, faces = _merge_vertices(pts, faces)
    _check_closed(path, faces, dim)
    if _signed_volume(pts, faces, dim) < 0:
        faces = faces[:, ::-1].copy()
    return pts.T.copy(), faces


def _merge_vertices(pts, faces, tol=1e-9):
    """STL repeats each vertex per triangle: merge coincident vertices (to ``tol`` of the size)."""
    scale = max(float(np.ptp(pts, axis=0).max()), 1e-300)
    key = np.round(pts / (tol * scale)).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    faces = inverse.ravel()[faces]
    keep = np.array([len(set(f)) == len(f) for f in faces])  # drop degenerate faces
    return pts[first], faces[keep]


def _check_closed(path, faces, dim):
    if dim == 2:
        edges = [(int(a), int(b)) for a, b in faces]
    else:
        edges = [(int(f[k]), int(f[(k + 1) % 3])) for f in faces for k in range(3)]
    count = {}
    for a, b in edges:
        count[(a, b)] = count.get((a, b), 0) + 1
    if dim == 2:
        starts, ends = np.bincount(faces[:, 0]), np.bincount(faces[:, 1], minlength=len(np.bincount(faces[:, 0])))
        n = max(len(starts), len(ends))
        starts, ends = np.pad(starts, (0, n - len(starts))), np.pad(ends, (0, n - len(ends)))
        bad = np.nonzero(starts != ends)[0]
        if bad.size:
            raise GeometryError(f"{path}: the outline is not closed or not consistently oriented at vertex "
                                f"{int(bad[0])} ({int(starts[bad[0]])} segments leave it, {int(ends[bad[0]])} arrive)")
        return
    for (a, b), c in count.items():
        if c > 1:
            raise GeometryError(f"{path}: inconsistent normals: the edge {a}-{b} is traversed the same way by "
                                f"{c} triangles (their orientations disagree, or the surface is not manifold)")
        if (b, a) not in count:
            raise GeometryError(f"{path}: the surface is not closed: the edge {a}-{b} belongs to one triangle only")


def _signed_volume(pts, faces, dim):
    if dim == 2:
        a, b = pts[faces[:, 0]], pts[faces[:, 1]]
        return 0.5 * float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))
    a, b, c = pts[faces[:, 0]], pts[faces[:, 1]], pts[faces[:, 2]]
    return float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, c)))) / 6.0


def face_elements(verts, faces, size, fluid_inside):
    """Boundary elements from a closed outward surface: each face is cut into pieces of
    about ``size`` (a length; 2D segments into equal parts, 3D triangles by midpoint
    each cut into m^2 similar triangles, m the least number of cuts per edge that brings the
    longest edge to at most sqrt(2) ``size``: about half a square of side ``size``). Returns x, n (out of the fluid:
    outward when the fluid is inside), S (length or area)."""
    dim = verts.shape[0]
    p = verts.T
    sign = 1.0 if fluid_inside else -1.0
    if dim == 2:
        xs, ns, ss = [], [], []
        for a, b in faces:
            d = p[b] - p[a]
            length = float(np.hypot(*d))
            k = max(1, int(round(length / size)))
            t = (0.5 + np.arange(k)) / k
            xs.append(p[a][:, None] + d[:, None] * t)
            # outward for a counter-clockwise outline is (dy, -dx)
            ns.append(np.repeat(sign * np.array([d[1], -d[0]])[:, None] / length, k, axis=1))
            ss.append(np.full(k, length / k))
        return np.concatenate(xs, axis=1), np.concatenate(ns, axis=1), np.concatenate(ss)
    tris = p[faces]  # (F, 3, 3)
    edge = np.max(np.linalg.norm(tris - np.roll(tris, 1, axis=1), axis=2), axis=1)
    cuts = np.maximum(1, np.ceil(edge / (np.sqrt(2) * size) - 1e-9)).astype(int)
    pieces = []
    for m in np.unique(cuts):  # each triangle into m^2 similar ones, m cuts per edge
        t = tris[cuts == m]
        a, b, c = t[:, 0], t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        for i in range(m):
            for j in range(m - i):
                corners = [(i, j), (i + 1, j), (i, j + 1)]
                pieces.append(np.stack([a + (u * b + v * c) / m for u, v in corners], axis=1))
                if i + j < m - 1:
                    corners = [(i + 1, j), (i + 1, j + 1), (i, j + 1)]
                    pieces.append(np.stack([a + (u * b + v * c) / m for u, v in corners], axis=1))
    tris = np.concatenate(pieces)
    cross = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    n = sign * cross / (2 * area[:, None])
    return tris.mean(axis=1).T.copy(), n.T.copy(), area


def inside(points, verts, faces):
    """Which of ``points`` (dim, N) lie inside the closed surface: the winding number
    (2D) or the solid angle sum of Van Oosterom & Strackee (1983) (3D), in chunks."""
    dim = verts.shape[0]
    p = verts.T
    q = points.T
    out = np.zeros(q.shape[0], dtype=bool)
    for s in range(0, q.shape[0], 4096):
        c = q[s:s + 4096][:, None, :]
        if dim == 2:
            a, b = p[faces[:, 0]][None] - c, p[faces[:, 1]][None] - c
            ang = np.arctan2(a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0], np.einsum("ijk,ijk->ij", a, b))
            out[s:s + 4096] = np.abs(ang.sum(axis=1)) > np.pi
        else:
            a, b, cc = (p[faces[:, k]][None] - c for k in range(3))
            la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, cc))
            num = np.einsum("ijk,ijk->ij", a, np.cross(b, cc))
            den = (la * lb * lc + np.einsum("ijk,ijk->ij", a, b) * lc + np.einsum("ijk,ijk->ij", b, cc) * la
                   + np.einsum("ijk,ijk->ij", cc, a) * lb)
            out[s:s + 4096] = np.abs(2 * np.arctan2(num, den).sum(axis=1)) > 2 * np.pi
    return out


def surface_distance(points, verts, faces, size):
    """An upper bound, within ``size``, of each point's distance to the surface: the
    distance to the nearest of the surface's sample points (the face pieces of edge
    ``size``/2 and the vertices)."""
    x, _, _ = face_elements(verts, faces, size / 2, True)
    samples = np.concatenate([x, verts], axis=1).T
    q = points.T
    d = np.full(q.shape[0], np.inf)
    for s in range(0, samples.shape[0], 2048):
        chunk = samples[s:s + 2048]
        for t in range(0, q.shape[0], 4096):
            dd = np.linalg.norm(q[t:t + 4096, None, :] - chunk[None], axis=2).min(axis=1)
            d[t:t + 4096] = np.minimum(d[t:t + 4096], dd)
    return d
