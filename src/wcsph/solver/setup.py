"""A case set up on a backend: the geometry sampled, the model and the integrator chosen, the
particle sets on the device, sorted, and the run state (``State``) that holds them."""
import math
from pathlib import Path

import numpy as np

from ..case import geometry
from ..case.config import _wall_sources
from . import parallel
from ..errors import CaseError
from ..backends.grid import Grid
from ..physics.integrators import INTEGRATORS, SPEC_SCHEMES
from ..physics.kernels import SUPPORT, kernel_numpy, kernel_params, smoothing_length
from ..models.wcsph import WCSPH
from ..boundaries.floating import part, wall_contacts
from ..boundaries.motion import Bodies
from ..boundaries.open_boundary import OpenBoundaries
from ..backends.particles import ParticleSet
from .state import State
from .walls import clock, place_walls


class Setup:
    """What ``build`` makes of a case: the run state, the integrator, the bodies (wall
    sources and their motions), the open boundaries (None without), the cfl and warnings."""

    def __init__(self, state, integrator, bodies, open_boundaries, cfl, warnings):
        self.state, self.integrator, self.bodies, self.open = state, integrator, bodies, open_boundaries
        self.cfl, self.warnings = cfl, warnings


def build(case, backend, comm):
    """Set up ``case`` (a validated case dict) on ``backend`` (a backend object), shared over
    ``comm`` (an MPI communicator, or None)."""
    dim, dtype, dp = case["dim"], np.dtype(case["precision"]).type, case["dp"]
    be, m = backend, case["model"]
    h = smoothing_length(case)
    geometry.check_size(case)
    ph = case["physics"]
    # Becker & Teschner's stiffness kappa is c0^2 of p = kappa rho0/gamma ((rho/rho0)^gamma - 1)
    c0 = math.sqrt(ph["kappa"]) if ph["kappa"] > 0 else ph["speed_of_sound"]
    fluid0 = None
    if not c0:  # the default's height and speed are the fluid's as sampled
        fluid0, wall0, lo, hi = geometry.build(case)
        c0 = default_sound_speed(case, fluid0)
    w_np, _ = kernel_numpy(m["kernel"], dim, h)
    model = WCSPH(case, be)
    gravity = np.asarray(ph["gravity"], dtype=float)
    column = _column(case, model, c0, h, gravity, w_np)
    if fluid0 is None or column is not None:  # a summation density's column: its boxes sampled compressed
        fluid0, wall0, lo, hi = geometry.build(case, column)
    opened = None
    if case["open_boundary"]:  # the buffers' particles join the fluid set, kind > 0
        opened = OpenBoundaries(case, dp, SUPPORT * h)
        fluid0 = _with_buffers(case, fluid0, opened, lo, hi, dp)
    grid = _grid(case, lo, hi, h)
    _check_indices(case, be, grid, fluid0["x"].shape[1] + wall0["x"].shape[1])
    warnings = list(case.get("_warnings", ()))  # settings that make results doubtful
    warnings += geometry.thin_obstacles(case) + geometry.short_blocks(case, column is not None)
    mass = model.particle_mass(dp, h, ph["rho0"], w_np)
    integrator, cfl = _integrator(case, be, model, warnings)
    if h < dp * (1 - 1e-9):
        warnings.append(f"h = {h:g} m is smaller than dp = {dp:g} m: a particle has almost no "
                        "neighbours and the SPH sums are meaningless")
    P = model.params(dict(kernel_params(m["kernel"], dim, h), rc=grid.support), ph["rho0"], c0, h, gravity, 1.0, w_np)

    x, v, cell0 = fluid0["x"], fluid0["v"], fluid0["cell"]
    rho = model.initial_density(x, fluid0["top"], P, gravity, fluid0["p"])
    ids = np.arange(x.shape[1], dtype=np.int64)  # follows the particle
    kind = fluid0.get("kind")
    par = None
    if comm is not None and comm.Get_size() > 1:  # every rank built the case: keep one's own
        par = _decomposition(case, comm, grid, be, np.concatenate([x, wall0["x"]], axis=1), opened)
        mine = par.split(x)
        x, v, rho, ids, cell0 = x[:, mine], v[:, mine], rho[mine], ids[mine], cell0[mine]
    elif model.refresh_fn is not None:
        integrator.fuse_refresh(model.refresh_fn)
    fluid = ParticleSet("fluid", dim, {"x": be.to_device(x.astype(dtype)), "v": be.to_device(v.astype(dtype))})
    for name, k, scratch in list(model.fluid_fields()) + list(integrator.fields):
        fluid.add(name, k, dtype, be, scratch=scratch)
    fluid["rho"] = be.to_device(rho.astype(dtype))
    fluid["m"] = be.to_device(model.initial_mass(mass, cell0, rho, ph["rho0"]).astype(dtype))
    fluid["id"] = be.to_device(ids)
    if kind is not None:
        fluid["kind"] = be.to_device(kind)  # 0 fluid, 1 + k the buffer of open_boundary[k]
    if par is None:
        integrator.fuse_first(model, fluid)

    body = wall0.pop("body")
    cell = wall0.pop("cell", None)  # a wall particle's lattice cell over dp^dim
    bodies = Bodies(geometry.wall_sources(case), dim, wall0["x"], wall0.get("n"), body, Path(case["_source"]).parent,
                    _floating_bodies(case), float(np.linalg.norm(case["physics"]["gravity"])))
    if bodies.floating:  # the walls a floating body meets: the fixed containers' faces, the fixed
        # obstacles it stays out of, and every other wall (``floating.Driven``)
        planes, blocks, bodies.driven = wall_contacts(_wall_sources(case), wall0["x"], body, bodies.motions,
                                                      bodies.centres, _meshes(case))
        for b, f in bodies.floating.items():
            f.meet(wall0["x"][:, body == b], planes, blocks)
        _clear_at_start(case, bodies)
    else:
        bodies.driven = []
    walls = ParticleSet("walls", dim, {k: be.to_device(a.astype(dtype)) for k, a in wall0.items()})
    walls.add("v", "vector", dtype, be)
    walls.add("a", "vector", dtype, be)  # the wall's acceleration (the wall pressure reads it)
    walls["body"] = be.to_device(body)  # the body each wall point belongs to
    # the points whose loads are asked for: those of the named and the floating bodies
    asked = [b for b, name in enumerate(bodies.names) if name or b in bodies.floating]
    walls["measured"] = be.to_device(np.isin(body, asked).astype(np.int64))
    if bodies.moving:  # the placement at t = 0 each moving wall point is carried from
        walls["x0"] = be.to_device(wall0["x"].astype(dtype))
        if "n" in wall0:
            walls["n0"] = be.to_device(wall0["n"].astype(dtype))
    for name, k in model.wall_fields():
        walls.add(name, k, dtype, be)
    if "psi" in walls.arrays and cell is not None:  # the lattice's pseudo-mass, sorted with the walls
        walls["psi"] = be.to_device((mass * cell).astype(dtype))

    halo = parallel.Halo(par, fluid) if par is not None else None
    state = State(case, be, grid, model, P, fluid, walls, domain=(lo, hi), h=h, c0=c0, mass=mass, par=par, halo=halo)
    state.vmax = float(np.max(np.linalg.norm(v, axis=0))) if v.shape[1] else 0.0
    place_walls(state, bodies, 0.0)
    state.walls_at = clock(state, bodies)
    be.sort(walls, grid)
    be.wrap(fluid, grid)
    if par is None:
        be.sort(fluid, grid)
    else:  # ghosts from the other ranks, then sorted with one's own
        par.redistribute(fluid)
    model.initialize(fluid, walls, P, state.G)
    return Setup(state, integrator, bodies, opened, cfl, warnings)


def _column(case, model, c0, h, gravity, w_np):
    """depth -> rho / rho0 of a column at rest under the case's gravity, by the model's EOS
    at p = rho0 |g| depth (as ``initial_density`` gives a continuity density), for a
    summation-density model, whose density is the particles' spacing; None for a continuity
    density (it starts hydrostatic in rho at the lattice's spacing), without gravity, and
    with a gravity ramp (the column then starts unloaded and settles as gravity comes on)."""
    g = abs(float(gravity[-1]))
    if model.continuity or g == 0 or case["physics"]["gravity_ramp_time"] > 0 or not case["fluid"]:
        return None
    rho0 = case["physics"]["rho0"]
    P = model.params(dict(kernel_params(case["model"]["kernel"], case["dim"], h), rc=SUPPORT * h), rho0, c0, h,
                     gravity, 1.0, w_np)
    Pd = P._replace(**{f: float(v) for f, v in P._asdict().items()})  # in double precision
    eos_density = model.q.eos_density
    return lambda depth: np.array([eos_density(Pd.p0 + rho0 * g * z, Pd) for z in np.ravel(depth)]) / rho0


def default_sound_speed(case, fluid0):
    """c0 = 10 max(sqrt(|g| H), |v0|): density varies by about 1 % (Monaghan 1994)."""
    x, v = fluid0["x"], fluid0["v"]
    g = float(np.linalg.norm(case["physics"]["gravity"]))
    height = float(x[-1].max() - x[-1].min()) + case["dp"]
    vmax = float(np.max(np.linalg.norm(v, axis=0))) if v.size else 0.0
    c0 = 10.0 * max(math.sqrt(g * height), vmax)
    if c0 == 0:
        raise CaseError(f"{case['_source']}: physics.speed_of_sound: must be set when "
                        "there is neither gravity nor an initial velocity")
    return c0


def _with_buffers(case, fluid0, opened, lo, hi, dp):
    bx, bv, bp, bkind = opened.initial_particles(geometry.lattice)
    out = ~np.all((bx >= lo[:, None]) & (bx <= hi[:, None]), axis=0)
    if out.any():
        raise CaseError(f"{case['_source']}: open_boundary: {int(out.sum())} buffer particles lie outside "
                        f"the domain {list(lo)} .. {list(hi)}")
    n = fluid0["x"].shape[1]
    return {"x": np.concatenate([fluid0["x"], bx], axis=1), "v": np.concatenate([fluid0["v"], bv], axis=1),
            "top": np.concatenate([fluid0["top"], np.full(bx.shape[1], bx[-1].max() + 0.5 * dp)]),
            "p": np.concatenate([fluid0["p"], bp]), "cell": np.concatenate([fluid0["cell"], np.ones(bx.shape[1])]),
            "kind": np.concatenate([np.zeros(n, dtype=np.int64), bkind])}


def _grid(case, lo, hi, h):
    """The cell grid over the domain, cells of the search radius (2h unless larger)."""
    rc = SUPPORT * h
    sr = case["model"]["searchRadius"]
    if sr > 0:
        if sr < rc * (1 - 1e-9):
            raise CaseError(f"{case['_source']}: model.searchRadius: {sr} is smaller than the kernel support 2h = {rc:g}")
        rc = sr
    try:
        return Grid.covering(lo, hi, rc, periodic=geometry.periodic_axes(case)[:case["dim"]])
    except ValueError as e:
        raise CaseError(f"{case['_source']}: domain.periodic: {e}") from None


def _check_indices(case, be, grid, n):
    """A clear error for a case whose particles (``n``, fluid and walls) or grid cells the
    backend's sort cannot address."""
    cells = grid.ncells + 2
    if max(n, cells) > be.max_index:
        what = f"{n:,} particles" if n > be.max_index else f"a neighbour grid of {cells:,} cells"
        raise CaseError(f"{case['_source']}: dp: {case['dp']:g} m makes {what}; the {be.name} backend addresses at "
                        f"most {be.max_index:,}. Use a larger dp or a smaller domain")


def _integrator(case, be, model, warnings):
    """The integrator of ``[time]`` (the model's default when none is named) and the cfl."""
    tc = case["time"]
    scheme = tc["integrator"] or model.default_integrator
    scheme = SPEC_SCHEMES.get(scheme, scheme)
    integrator = INTEGRATORS[scheme](be, case["dim"], model.continuity, np.dtype(case["precision"]).type,
                                     settings=dict(tc, adaptive=tc["dt"] <= 0))
    cfl = tc["cfl"] or integrator.default_cfl()
    stable = integrator.stable_cfl
    if tc["cfl"] and tc["dt"] <= 0 and model.continuity and stable and tc["cfl"] > stable:
        warnings.append(f"time.cfl = {tc['cfl']:g} is past the largest stable value measured for "
                        f"{scheme} ({stable:g}, benchmarks/integrators.py); leave time.cfl out for its "
                        f"default ({integrator.default_cfl():g})")
    return integrator, cfl


def _floating_bodies(case):
    """{body index: FloatingBody} of the case's floating wall sources."""
    from ..boundaries.floating import body_of
    from ..io.readers import read_surface

    out = {}
    for b, (key, table) in enumerate(_wall_sources(case)):
        if table.get("floating") is None:
            continue
        mesh = None
        if table.get("mesh"):
            mesh = read_surface(Path(case["_source"]).parent / table["mesh"], case["dim"])
        out[b] = body_of(key, table, case["dim"], mesh, case["physics"]["rho0"])
    return out


def _clear_at_start(case, bodies):
    """A case error when a floating body starts inside a wall or another body: the contacts
    (``floating.part``) would move it out at its first step, a jump the case did not ask
    for. Tried on copies; a push of up to dp/100 (round-off, a face laid on a face) passes."""
    import copy

    moving = {b: copy.deepcopy(f) for b, f in bodies.floating.items()}
    for f in moving.values():
        f.settle()
    part(list(moving.values()), [copy.deepcopy(d).at(0.0) for d in bodies.driven])
    sources = _wall_sources(case)
    for b, f in moving.items():
        push = float(np.linalg.norm(f.c - bodies.floating[b].c))
        if push > 0.01 * case["dp"]:
            raise CaseError(f"{case['_source']}: {sources[b][0]}: the floating body starts inside a wall or another "
                            f"body (the contacts would push it {push:.3g} m out at its first step); place it clear")


def _meshes(case):
    """{"walls[k]": (vertices, faces)} of the case's wall meshes that do not float."""
    from ..io.readers import read_surface

    return {f"walls[{k}]": read_surface(Path(case["_source"]).parent / w["mesh"], case["dim"])
            for k, w in enumerate(case["walls"]) if w.get("mesh") and w.get("floating") is None}


def _decomposition(case, comm, grid, be, occupied, opened):
    if opened is not None:
        raise CaseError(f"{case['_source']}: open_boundary: open boundaries run on one process only "
                        "(buffers create and remove particles); run the case without mpiexec")
    pc = case["parallel"]
    try:
        return parallel.Decomposition(comm, grid, be, pc["axis"], pc["balance_threshold"], pc["balance_interval"],
                                      extent=np.ptp(occupied, axis=1), balance=pc["balance"])
    except ValueError as e:
        raise CaseError(f"{case['_source']}: parallel.axis: {e}") from None
