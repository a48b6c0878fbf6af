"""The free surface as a mesh: the iso-line (2D) or iso-surface (3D) c = 1/2 of the fluid's
color function c(x) = sum_j W(x - x_j) V_j on a regular grid of nodes, by marching squares
or cubes (scikit-image). c is about 1 inside the fluid, falls to 1/2 where the particles'
volumes end and to 0 a kernel support away: its 1/2 crossing is the free surface of
DualSPHysics' IsoSurface and of the level gauges (``probes``). Where the fluid lies on a wall
the surface closes along the wall's face, so a frame's surface is closed: ParaView can take
its volume, clip it and colour it.

The nodes span the fluid's bounding box and a kernel support beyond it, every ``spacing``
(default dp/2). The sum is one pass of the CPU backend over the nodes, from host copies of the
particles (a run writes them for its frame anyway): the same on every backend, and for a
finished run's frames (``wcsph surface RUN_DIR``).
"""
from collections import namedtuple

import numpy as np
from numba.extending import register_jitable

from ..backends.cpu import CpuBackend
from ..backends.grid import Grid
from ..physics.kernels import SUPPORT, kernel_params, make_kernel
from ..backends.particles import ParticleSet
from .vtk import atomic

#: the kernel factors and the search radius the pass reads
SurfaceParams = namedtuple("SurfaceParams", "rc2 h_inv w_norm g_norm")
Nodes = namedtuple("Nodes", "x color cell start")
Volumes = namedtuple("Volumes", "x vol cell start")
#: the iso-value of the surface
LEVEL = 0.5

_PASSES = {}


def _color_pass(dim, kernel):
    key = (dim, kernel)
    if key not in _PASSES:
        w = make_kernel(kernel, np.float64)[0]
        zero = np.float64(0)

        @register_jitable
        def init(i, I, P):
            return zero

        @register_jitable
        def pair(i, j, dx, dy, dz, r, I, J, P, acc):
            return acc + w(r, P) * J.vol[j]

        @register_jitable
        def store(i, I, P, acc):
            I.color[i] = acc

        _PASSES[key] = CpuBackend().make_pass(dim, np.float64, init, pair, store)
    return _PASSES[key]


def color_function(x, vol, h, kernel, spacing):
    """(origin, spacing, c) with c the color function on the nodes origin + spacing * index,
    an array of shape (nx, ny[, nz]); ``x`` (dim, N) and ``vol`` (N,) of the fluid."""
    dim = x.shape[0]
    support = SUPPORT * h
    lo = x.min(axis=1) - support - spacing
    hi = x.max(axis=1) + support + spacing
    counts = np.ceil((hi - lo) / spacing).astype(int) + 1
    axes = [lo[a] + spacing * np.arange(counts[a]) for a in range(dim)]
    nodes = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")])
    be = CpuBackend()
    grid = Grid.covering(lo - spacing, lo + spacing * counts, support)  # the nodes a spacing inside
    fluid = ParticleSet("fluid", dim, {"x": np.ascontiguousarray(x, dtype=np.float64),
                                       "vol": np.ascontiguousarray(vol, dtype=np.float64)})
    be.sort(fluid, grid)
    pts = ParticleSet("nodes", dim, {"x": nodes, "color": np.zeros(nodes.shape[1]),
                                     "order": np.arange(nodes.shape[1], dtype=np.int64)})
    if be.sort(pts, grid):
        raise RuntimeError("a surface node lies outside its cell grid")
    kp = kernel_params(kernel, dim, h)
    P = SurfaceParams(support * support, kp["h_inv"], kp["w_norm"], kp["g_norm"])
    _color_pass(dim, kernel)(pts.view(Nodes), fluid.view(Volumes), fluid.view(Volumes), P, grid.view())
    c = np.zeros(nodes.shape[1])
    c[pts["order"]] = pts["color"]
    return lo, spacing, c.reshape(tuple(counts))


def surface_mesh(x, vol, h, kernel, spacing):
    """(points (n, 3), cells, kind): the free surface's triangles (3D, kind "triangle") or
    line segments (2D, kind "line"), cells as (m, 3) or (m, 2) point indices; empty arrays
    when there is no fluid."""
    from skimage import measure

    dim = x.shape[0]
    corners = 3 if dim == 3 else 2
    kind = "triangle" if dim == 3 else "line"
    if x.shape[1] == 0:
        return np.zeros((0, 3)), np.zeros((0, corners), dtype=np.int64), kind
    lo, s, c = color_function(x, vol, h, kernel, spacing)
    if c.max() < LEVEL:  # too few particles to reach the level anywhere
        return np.zeros((0, 3)), np.zeros((0, corners), dtype=np.int64), kind
    if dim == 3:
        verts, faces, _, _ = measure.marching_cubes(c, level=LEVEL, spacing=(s, s, s))
        pts = verts + lo
        return pts, faces.astype(np.int64), kind
    pts, segs = [], []
    for line in measure.find_contours(c, LEVEL):  # (row, col) = (i, j) fractional indices
        k0 = sum(len(p) for p in pts)
        pts.append(lo + s * line)
        segs.append(np.stack([np.arange(len(line) - 1), np.arange(1, len(line))], axis=1) + k0)
    p2 = np.concatenate(pts)
    return np.column_stack([p2, np.zeros(len(p2))]), np.concatenate(segs).astype(np.int64), kind


def write_surface(path, points, cells, kind):
    """The surface as a .vtu of triangles or lines (ParaView reads it as any mesh)."""
    import meshio

    with atomic(path) as tmp:
        meshio.Mesh(points, [(kind, cells)] if len(cells) else []).write(tmp, file_format="vtu")


def from_run(directory, spacing=None):
    """The free surface of every frame of a finished run in ``directory`` (its ``fluid.pvd``
    and ``run.json``): ``surface_NNNN.vtu`` beside each frame and ``surface.pvd``; the number
    of frames. A ValueError names what is missing."""
    import json
    import xml.etree.ElementTree as ET
    from pathlib import Path

    import meshio

    from .vtk import write_pvd

    d = Path(directory)
    try:
        run = json.loads((d / "run.json").read_text())
        series = ET.parse(d / "fluid.pvd").getroot()
    except (OSError, ValueError, ET.ParseError) as e:
        raise ValueError(f"{d}: needs the run's run.json and fluid.pvd ({e})") from None
    missing = [k for k in ("dim", "h", "dp", "particle_mass") if k not in run]
    if missing:
        raise ValueError(f"{d}/run.json: lacks {', '.join(missing)}")
    dim, h, mass = run["dim"], run["h"], run["particle_mass"]
    s = spacing or 0.5 * run["dp"]
    entries = []
    for k, ds in enumerate(series.iter("DataSet")):
        frame = d / ds.get("file")
        files = ([frame.parent / p.get("Source") for p in ET.parse(frame).getroot().iter("Piece")]
                 if frame.suffix == ".pvtu" else [frame])
        try:
            meshes = [meshio.read(f) for f in files]
        except (OSError, ValueError) as e:
            raise ValueError(f"{frame}: cannot read it ({e})") from None
        x = np.concatenate([m.points[:, :dim].T for m in meshes], axis=1)
        rho = np.concatenate([np.asarray(m.point_data["rho"], dtype=float) for m in meshes])
        # each particle's own mass where the frame has it (a fitted box's cells, a continuity
        # density's rho(0) V_cell differ from run.json's particle_mass by up to 1 %)
        own = all("m" in piece.point_data for piece in meshes)
        masses = np.concatenate([np.asarray(piece.point_data["m"], dtype=float) for piece in meshes]) if own else mass
        name = f"surface_{k:04d}.vtu"
        write_surface(d / name, *surface_mesh(x, masses / rho, h, run.get("kernel", "wendland"), s))
        entries.append((float(ds.get("timestep")), 2, name))
    write_pvd(d / "surface.pvd", entries)
    return len(entries)
