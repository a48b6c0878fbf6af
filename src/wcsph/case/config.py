"""Case description: a TOML file, or the same nested dict from Python.

The schema below is the single source of truth for keys, types, defaults and limits. Every
problem is reported as a ``CaseError`` naming the file and the dotted key, e.g.
``dam.toml: model.xsph_epsilon: expected a number, got 'high'``. The ``[model]`` table is
built from the plug-in registries (``physics.slots``).
"""
import copy
import math
import re
import tomllib
from pathlib import Path

from ..physics import integrators, slots
from ..errors import CaseError
from ..boundaries.floating import FLOATING, holds_fluid
from ..boundaries.motion import MOTION
from ..boundaries.open_boundary import OPEN_BOUNDARY
from ..boundaries.open_boundary import check as check_open_boundaries
from ..physics.registry import NONNEG, POS, REQUIRED, one_of

CASES_DIR = Path(__file__).parents[1] / "cases"  # src/wcsph/cases


# ---------------------------------------------------------------------------------- schema
# leaf: (kind, default, check) where kind is a type tag and check a (predicate, message)


#: a case name becomes the directory runs/NAME: one path component, no way out of runs/
SAFE_NAME = (lambda v: bool(re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", v)) and ".." not in v,
             "must be letters, digits, '_', '-' or '.' (it names the output directory runs/NAME)")
BLOCK = {"min": ("vec", REQUIRED, None), "max": ("vec", REQUIRED, None)}
#: initial velocity and pressure: numbers or formulas of x, y, z (``expressions``)
#: a fluid block is a box (min, max), a point ``file`` (CSV or VTK) or a closed ``surface``
#: mesh to fill (``io.readers``)
FLUID_BLOCK = {"min": ("vec", None, None), "max": ("vec", None, None), "file": ("str", "", None),
               "surface": ("str", "", None), "velocity": ("field", None, None), "pressure": ("formula", None, None),
               # "lattice": whole spacings of dp from min; "fitted": round(L/dp) spacings of L/n along
               # each axis, the particles' mass the cell's (``geometry.fitted_lattice``)
               "fill": ("str", "lattice", one_of("lattice", "fitted"))}
#: what every wall source (tank, obstacle, polygon) may add: a body name (its force and torque
#: go to probes.csv) and a prescribed motion (``motion.MOTION``) or a ``floating`` table (a
#: rigid body moved by the fluid and gravity, ``floating.FLOATING``)
BODY = {"name": ("str", "", None), "motion": (MOTION, None, None), "floating": (FLOATING, None, None)}
#: a 2D wall along a polyline; the fluid lies on the left of the direction of travel
POLYGON = dict({"points": ("points", REQUIRED, None), "closed": ("bool", False, None)}, **BODY)
#: walls from a file: a point ``file`` (boundary elements need the normals and sizes, wall
#: particles only the points) or a closed surface ``mesh`` (STL, OBJ, VTK...); ``fluid_side``
#: says whether the fluid is inside the mesh (a tank) or outside (a body)
WALL_FILE = dict({"file": ("str", "", None), "mesh": ("str", "", None),
                  "fluid_side": ("str", "outside", one_of("inside", "outside"))}, **BODY)
#: pressure sensor at ``position``; water-level gauge along the vertical line from
#: ``position`` up by ``length`` (0: to the top of the domain); ``extrapolate``: a pressure
#: sensor carries each particle's p to the point along the momentum equation's grad p
#: a ``[[damping]]`` zone (``solver.damping``): a box where waves are absorbed
DAMPING = {"min": ("vec", REQUIRED, None), "max": ("vec", REQUIRED, None), "direction": ("vec", None, None),
           "strength": ("float", 10.0, POS)}
#: a ``[[grids]]`` table: nodes origin + sum_a i_a axes[a] / (counts[a] - 1), i_a = 0 .. counts[a] - 1
GRID = {"name": ("str", REQUIRED, None), "origin": ("vec", REQUIRED, None), "axes": ("axes", REQUIRED, None),
        "counts": ("counts", REQUIRED, None), "interval": ("float", 0.0, NONNEG)}
PROBE = {"name": ("str", REQUIRED, None), "kind": ("str", REQUIRED, one_of("pressure", "level", "flow")),
         "normal": ("vec", None, None),
         "position": ("vec", REQUIRED, None), "length": ("float", 0.0, NONNEG),
         "extrapolate": ("bool", False, None),
         "method": ("str", "kernel_sum", one_of("kernel_sum", "volume"))}

#: the runtime parameters of the WCSPH-BI spec, accepted flat in a ``[parameters]`` table
#: under the spec's names, and where each one lives in the case: those of the plug-in
#: choices come from the registries (``Param(spec=True)``), these from the rest of the case
SPEC_PARAMETERS = dict({
    "dp": "dp", "speedOfSound": "physics.speed_of_sound", "rho0": "physics.rho0", "dtInit": "time.dtInit",
    "cfl": "time.cfl", "dtMin": "time.dtMin", "gravity": "physics.gravity",
}, **integrators.spec_parameters(), **slots.spec_parameters())

SCHEMA = {
    "name": ("str", "case", SAFE_NAME),
    "description": ("str", "", None),
    "dim": ("int", REQUIRED, one_of(2, 3)),
    "dp": ("float", REQUIRED, POS),
    "precision": ("str", "float32", one_of("float32", "float64")),
    "backend": ("str", "cpu", one_of("cpu", "cuda")),
    # periodic: a flag per axis; the box [min, max) (or the tank's along that axis) repeats
    "domain": ({"min": ("vec", None, None), "max": ("vec", None, None), "periodic": ("flags", None, None)},
               None, None),
    "fluid": ([FLUID_BLOCK], REQUIRED, None),
    "tank": (dict(BLOCK, open_top=("bool", True, None), **BODY), None, None),
    "obstacle": ([dict(BLOCK, **BODY)], [], None),
    "polygon": ([POLYGON], [], None),
    "walls": ([WALL_FILE], [], None),
    # inflow and outflow buffers (``open_boundary``)
    "open_boundary": ([OPEN_BOUNDARY], [], None),
    "physics": (dict({
        "rho0": ("float", 1000.0, POS),
        "gravity": ("vec", None, None),
        "speed_of_sound": ("float", 0.0, NONNEG),
        "p0": ("float", 0.0, None),
        "kappa": ("float", 0.0, NONNEG),
        "gravity_ramp_time": ("float", 0.0, NONNEG),
    }, **slots.physics_params()), {}, None),
    # the preset, one key per plug-in slot and every choice's parameters (``physics.slots``)
    "model": (slots.model_schema(), {}, None),
    "time": ({
        "end": ("float", REQUIRED, POS),
        **integrators.time_schema(),
        "cfl": ("float", 0.0, NONNEG),  # 0: the integrator's own default
        "force_cfl": ("float", 0.25, POS),
        "dt": ("float", 0.0, NONNEG),
        "dtInit": ("float", 0.0, NONNEG),
        "dtMin": ("float", 0.0, NONNEG),
        "max_steps": ("int", 0, NONNEG),
        # steps between the host's reads of a GPU's checks at a constant dt (solver.check)
        "check_interval": ("int", 10, POS),
    }, REQUIRED, None),
    "probes": ([PROBE], [], None),
    "grids": ([GRID], [], None),
    "damping": ([DAMPING], [], None),
    # a run on several MPI ranks (``mpiexec -n N wcsph run``): slabs along ``axis`` (auto: the
    # longest), cuts moved when the particles per rank (``balance = "time"``: the seconds of
    # work per rank) differ from the mean by more than ``balance_threshold``, checked every
    # ``balance_interval`` steps (0: never)
    "parallel": ({
        "axis": ("str", "auto", one_of("auto", "x", "y", "z")),
        "balance": ("str", "count", one_of("count", "time")),
        "balance_threshold": ("float", 0.1, POS),
        "balance_interval": ("int", 20, NONNEG),
    }, {}, None),
    "output": ({
        "interval": ("float", 0.0, NONNEG),
        "checkpoint_interval": ("float", 0.0, NONNEG),
        "probe_interval": ("float", 0.0, NONNEG),
        "vtk": ("bool", True, None),
        "surge_front": ("bool", False, None),
        "progress": ("bool", True, None),
        "surface": ("bool", False, None),
        "surface_spacing": ("float", 0.0, NONNEG),
    }, {}, None),
}


def _fail(src, key, msg):
    raise CaseError(f"{src}: {key}: {msg}")


def _leaf(src, key, kind, value, dim):
    if kind == "str":
        if not isinstance(value, str):
            _fail(src, key, f"expected a string, got {value!r}")
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            _fail(src, key, f"expected true or false, got {value!r}")
        return value
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            _fail(src, key, f"expected an integer, got {value!r}")
        return value
    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            _fail(src, key, f"expected a number, got {value!r}")
        if not math.isfinite(value):
            _fail(src, key, f"must be finite, got {value!r}")
        return float(value)
    if kind == "vec":
        if not isinstance(value, list) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value
        ):
            _fail(src, key, f"expected a list of {dim} numbers, got {value!r}")
        if dim is not None and len(value) != dim:
            _fail(src, key, f"expected {dim} components (dim = {dim}), got {len(value)}")
        return [float(v) for v in value]
    if kind == "formula":
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return _leaf(src, key, "float", value, dim)
        if not isinstance(value, str):
            _fail(src, key, f"expected a number or a formula of x, y, z, got {value!r}")
        from ..io.expressions import ExpressionError, check

        try:
            check(value)
        except ExpressionError as e:
            _fail(src, key, f"{value!r}: {e}")
        return value
    if kind == "field":
        if not isinstance(value, list) or (dim is not None and len(value) != dim):
            _fail(src, key, f"expected a list of {dim} numbers or formulas, got {value!r}")
        return [_leaf(src, f"{key}[{a}]", "formula", v, dim) for a, v in enumerate(value)]
    if kind == "flags":
        if not isinstance(value, list) or not all(isinstance(v, bool) for v in value):
            _fail(src, key, f"expected a list of {dim} true/false values, got {value!r}")
        if dim is not None and len(value) != dim:
            _fail(src, key, f"expected {dim} components (dim = {dim}), got {len(value)}")
        return value
    if kind == "rotation_flags":  # one per rotation axis: 2D one (about z), 3D three
        n = 1 if dim == 2 else 3
        if not isinstance(value, list) or len(value) != n or not all(isinstance(v, bool) for v in value):
            _fail(src, key, f"expected a list of {n} true/false value{'s' if n > 1 else ''} (rotation "
                  f"{'about z' if n == 1 else 'about x, y and z'}), got {value!r}")
        return value
    if kind == "axes":
        if not isinstance(value, list) or not 1 <= len(value) <= (dim or 3) or not all(isinstance(a, list) for a in value):
            _fail(src, key, f"expected a list of 1 to {dim} edge vectors, e.g. [[1.0, 0.0], [0.0, 0.5]], got {value!r}")
        axes = [_leaf(src, f"{key}[{k}]", "vec", a, dim) for k, a in enumerate(value)]
        used = []
        for k, a in enumerate(axes):
            nz = [c for c, v in enumerate(a) if v != 0]
            if len(nz) != 1 or a[nz[0]] < 0 or nz[0] in used:
                _fail(src, f"{key}[{k}]", f"{a}: each edge must lie along a different one of +x, +y"
                      f"{', +z' if dim == 3 else ''} (a grid ParaView reads as an image)")
            used.append(nz[0])
        return axes
    if kind == "counts":
        if not isinstance(value, list) or not all(isinstance(v, int) and not isinstance(v, bool) and v >= 2
                                                  for v in value):
            _fail(src, key, f"expected a list of node counts, each an integer of at least 2, got {value!r}")
        return value
    if kind == "points":
        if not isinstance(value, list) or len(value) < 2:
            _fail(src, key, f"expected a list of at least two points, got {value!r}")
        return [_leaf(src, f"{key}[{k}]", "vec", p, dim) for k, p in enumerate(value)]
    raise AssertionError(kind)


#: keys of earlier versions, and what they are called now
RENAMED = {"model.enableShifting": "model.enableNearBoundaryShifting (NBVC-PST; the bulk's shifting is the "
                                   "`shifting` slot)"}


def _validate(src, prefix, schema, data, dim):
    if not isinstance(data, dict):
        _fail(src, prefix.rstrip("."), f"expected a table, got {data!r}")
    unknown = sorted(set(data) - set(schema))
    if unknown:
        if prefix + unknown[0] in RENAMED:
            _fail(src, prefix + unknown[0], f"renamed: write {RENAMED[prefix + unknown[0]]}")
        _fail(src, prefix + unknown[0], "unknown key; known keys here: " + ", ".join(sorted(schema)))
    out = {}
    for name, (kind, default, check) in schema.items():
        key = prefix + name
        if name not in data:
            if default is REQUIRED:
                _fail(src, key, "missing (required)")
            out[name] = _normalise(src, key, kind, copy.deepcopy(default), dim)
            continue
        value = data[name]
        out[name] = _validate_value(src, key, kind, value, dim)
        if check is not None and not check[0](out[name]):
            _fail(src, key, f"{check[1]}, got {value!r}")
    return out


def _normalise(src, key, kind, default, dim):
    if isinstance(kind, dict) and default is not None:
        return _validate(src, key + ".", kind, default, dim)
    return default


def _validate_value(src, key, kind, value, dim):
    if isinstance(kind, dict):
        return _validate(src, key + ".", kind, value, dim)
    if isinstance(kind, list):
        if isinstance(value, dict):
            value = [value]
        if not isinstance(value, list):
            _fail(src, key, f"expected a list of tables, got {value!r}")
        return [_validate(src, f"{key}[{k}].", kind[0], v, dim) for k, v in enumerate(value)]
    return _leaf(src, key, kind, value, dim)


def validate(data, src="<case>"):
    """Check ``data`` against the schema; return a complete case dict with defaults filled."""
    if not isinstance(data, dict):
        raise CaseError(f"{src}: expected a table at the top level")
    dim = data.get("dim")
    dim = _leaf(src, "dim", "int", dim, None) if dim is not None else None
    if dim not in (2, 3):
        _fail(src, "dim", f"must be 2 or 3, got {dim!r}")
    data = _lift_parameters(src, data)
    case = _validate(src, "", SCHEMA, data, dim)
    given = data.get("model") if isinstance(data.get("model"), dict) else {}
    slots.resolve(case["model"])
    errors, warnings = slots.problems(case["model"], set(given))
    if errors:
        _fail(src, *errors[0])
    if case["polygon"] and dim != 2:
        _fail(src, "polygon", "polygon walls are 2D only; use tank and obstacle boxes in 3D")
    for k, poly in enumerate(case["polygon"]):
        problem = _outline_problem(poly["points"], poly["closed"])
        if problem:
            _fail(src, f"polygon[{k}].points", problem)
    for k, probe in enumerate(case["probes"]):
        if sum(p["name"] == probe["name"] for p in case["probes"]) > 1:
            _fail(src, f"probes[{k}].name", f"{probe['name']!r} is used by two probes")
        if probe["kind"] == "flow" and (probe["normal"] is None or not any(probe["normal"])):
            _fail(src, f"probes[{k}].normal", "a flow section needs the normal of its plane (the direction "
                  "the flux counts as positive), e.g. normal = [1.0, 0.0]")
    for k, z in enumerate(case["damping"]):
        _check_box(src, f"damping[{k}]", z)
        if z["direction"] is not None and not any(z["direction"]):
            _fail(src, f"damping[{k}].direction", "must not be zero (the way the waves run into the zone)")
    for k, g in enumerate(case["grids"]):
        if len(g["counts"]) != len(g["axes"]):
            _fail(src, f"grids[{k}].counts", f"one count per edge: {len(g['axes'])} edges, {len(g['counts'])} counts")
        if sum(o["name"] == g["name"] for o in case["grids"]) > 1 or not re.fullmatch(r"[A-Za-z0-9_.-]+", g["name"]):
            _fail(src, f"grids[{k}].name", f"{g['name']!r}: a name of letters, digits, '_', '-' or '.', used "
                  "by one grid only (it names the grid's files)")
    ph = case["physics"]
    if ph["kappa"] > 0 and ph["speed_of_sound"] > 0:
        _fail(src, "physics.kappa", "give kappa or speed_of_sound, not both (kappa = c0^2)")
    if ph["gravity"] is None:
        case["physics"]["gravity"] = [0.0] * (dim - 1) + [-9.81]
    for k, b in enumerate(case["fluid"]):
        given = [name for name in ("min", "file", "surface") if b[name]]
        if (b["min"] is None) != (b["max"] is None):
            _fail(src, f"fluid[{k}]", "give both min and max, or neither")
        if len(given) != 1:
            _fail(src, f"fluid[{k}]", "give one of min and max (a box), file (points) or surface (a closed mesh "
                  f"to fill); got {', '.join(given) or 'none'}")
        if b["min"] is not None:
            _check_box(src, f"fluid[{k}]", b)
    for k, b in enumerate(case["obstacle"]):
        _check_box(src, f"obstacle[{k}]", b)
    for k, w in enumerate(case["walls"]):
        if bool(w["file"]) == bool(w["mesh"]):
            _fail(src, f"walls[{k}]", "give file (a point set) or mesh (a closed surface), one of them")
    if case["tank"] is not None:
        _check_box(src, "tank", case["tank"])
    if not case["fluid"]:
        _fail(src, "fluid", "no fluid block: give at least one [[fluid]] with min and max")
    blocks = [(k, b) for k, b in enumerate(case["fluid"]) if b["min"] is not None]
    for i, (a, A) in enumerate(blocks):
        for b, B in blocks[i + 1:]:
            lo = [max(p, q) for p, q in zip(A["min"], B["min"])]
            hi = [min(p, q) for p, q in zip(A["max"], B["max"])]
            if all(h - l > 1e-9 for l, h in zip(lo, hi)):
                _fail(src, f"fluid[{b}]", f"overlaps fluid[{a}] (in {_num(lo)} .. {_num(hi)}); particles "
                      "placed twice start on top of each other")
    for key, b in _wall_sources(case):
        fl = b.get("floating")
        if fl is None:
            continue
        if key == "tank":
            _fail(src, "tank.floating", "the tank cannot float; make the body an obstacle, a polygon or a wall mesh")
        if b["motion"] is not None:
            _fail(src, f"{key}.floating", "a body is either floating or moved by its motion, not both")
        if not b["name"]:
            _fail(src, f"{key}.name", "a floating body needs a name (its position, velocity and loads go to "
                  "probes.csv under it)")
        if (fl["density"] > 0) == (fl["mass"] > 0) or fl["density"] < 0 or fl["mass"] < 0:
            _fail(src, f"{key}.floating", "give the body's density or its mass (> 0), one of the two")
        if fl["added_mass"] < 0:
            _fail(src, f"{key}.floating.added_mass", "the relaxation's added mass coefficient, >= 0 (0: none)")
        if fl["release"] < 0:
            _fail(src, f"{key}.floating.release", "the time the body is released, >= 0")
        if fl["inertia"] < 0 or (fl["inertia"] > 0 and dim == 3):
            _fail(src, f"{key}.floating.inertia", "a 2D body's moment of inertia about its centre (> 0); a 3D "
                  "body's inertia tensor comes from its geometry")
        if fl["hinge"] is not None and fl["translation"] is not None:
            _fail(src, f"{key}.floating.translation", "a hinged body moves only by turning about its hinge: give "
                  "the hinge or the free translation axes, not both")
        if fl["rotation"] is not None and fl["hinge"] is not None and not any(fl["rotation"]):
            _fail(src, f"{key}.floating.rotation", "a hinged body that cannot turn cannot move: free a rotation")
        if key.startswith("polygon") and not b["closed"]:
            _fail(src, f"{key}.closed", "a floating polygon must be closed (its area gives its mass)")
        if key.startswith("polygon") and holds_fluid(b["points"]):
            _fail(src, f"{key}.points", "a floating polygon's points must run clockwise: the fluid is on "
                  "the left of a polygon wall, and a body's fluid is outside it")
    names = [(key, b["name"]) for key, b in _wall_sources(case) if b["name"]]
    for k, (key, name) in enumerate(names):
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
            _fail(src, f"{key}.name", f"must be letters, digits and '_' (it names probes.csv columns), got {name!r}")
        if any(name == other for _, other in names[:k]):
            _fail(src, f"{key}.name", f"{name!r} names two bodies")
    d = case["domain"]
    if d is not None and (d["min"] is None) != (d["max"] is None):
        _fail(src, "domain", "give both min and max, or neither")
    if d is not None and d["min"] is not None:
        _check_box(src, "domain", d)
    if d is not None and d["periodic"] is not None and any(d["periodic"]):
        if d["min"] is None and case["tank"] is None:
            _fail(src, "domain.periodic", "a periodic axis needs the box that repeats: give domain.min and "
                  "domain.max (or a tank)")
        box = d if d["min"] is not None else case["tank"]
        for a, on in enumerate(d["periodic"]):
            length = box["max"][a] - box["min"][a]
            cells = length / case["dp"]
            if on and abs(cells - round(cells)) > 1e-6 * max(cells, 1):
                _fail(src, "domain.periodic", f"the periodic length {length:g} along axis {a} is not a whole "
                      f"number of dp = {case['dp']:g} (the lattice would not join up across the seam)")
    warnings = warnings + check_open_boundaries(src, case, _fail)
    if case["open_boundary"] and (d is None or d["min"] is None):
        _fail(src, "domain", "open boundaries need the domain box (domain.min and domain.max) that holds the "
              "buffers; particles beyond it are removed")
    case["_source"] = src
    case["_warnings"] = warnings
    return case


def _outline_problem(points, closed):
    """Why a polygon's ``points`` make no wall (None when they do): two points in a row the
    same (a side of no length); closed, fewer than three points, no area, or two sides that
    cross (its inside, the side its fluid is on, is then not one region)."""
    import numpy as np

    a = np.asarray(points, dtype=float)
    b = np.roll(a, -1, axis=0) if closed else a[1:]
    a = a if closed else a[:-1]
    size = float(np.max(np.ptp(np.vstack([a, b]), axis=0)))
    d = b - a
    short = np.flatnonzero(np.hypot(d[:, 0], d[:, 1]) <= 1e-12 * size)
    if short.size or size == 0.0:
        k = int(short[0]) if short.size else 0
        return f"points {k} and {(k + 1) % len(points)} are the same point: a side of no length"
    if not closed:
        return None
    if len(points) < 3:
        return "a closed polygon needs at least three points"

    def cross(u, v):
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    m = len(a)
    for i0 in range(0, m, 256):  # every pair of sides that do not share a point, in blocks
        i = np.arange(i0, min(m, i0 + 256))[:, None]
        j = np.arange(m)[None, :]
        o1, o2 = cross(d[i], a[j] - a[i]), cross(d[i], b[j] - a[i])
        o3, o4 = cross(d[j], a[i] - a[j]), cross(d[j], b[i] - a[j])
        apart = (j > i + 1) & ~((i == 0) & (j == m - 1))
        hit = np.argwhere(apart & (o1 * o2 < 0) & (o3 * o4 < 0))
        if hit.size:
            s, t = int(i0 + hit[0][0]), int(hit[0][1])
            return (f"sides {s} ({s} -> {(s + 1) % m}) and {t} ({t} -> {(t + 1) % m}) cross: a closed polygon "
                    "must not cross itself (the side its fluid is on would change along it)")
    if abs(float(np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]))) <= 1e-12 * size * size:
        return "the closed polygon encloses no area (its points lie on a line)"
    return None


def _wall_sources(case):
    """(key, table) of every wall source of a validated case, in the order walls are built."""
    out = [("tank", case["tank"])] if case["tank"] is not None else []
    out += [(f"obstacle[{k}]", b) for k, b in enumerate(case["obstacle"])]
    out += [(f"polygon[{k}]", b) for k, b in enumerate(case["polygon"])]
    out += [(f"walls[{k}]", b) for k, b in enumerate(case["walls"])]
    return out


def _lift_parameters(src, data):
    """Move ``[parameters]`` (the spec's flat names) to where each lives in the case."""
    params = data.get("parameters")
    if params is None:
        return data
    if not isinstance(params, dict):
        _fail(src, "parameters", f"expected a table, got {params!r}")
    data = copy.deepcopy(data)
    del data["parameters"]
    for name, value in params.items():
        if name not in SPEC_PARAMETERS:
            _fail(src, f"parameters.{name}", "unknown parameter; known: " + ", ".join(sorted(SPEC_PARAMETERS)))
        *path, last = SPEC_PARAMETERS[name].split(".")
        node = data
        for part in path:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                _fail(src, part, f"expected a table, got {node!r}")
        if last in node:
            _fail(src, f"parameters.{name}", f"also given as {SPEC_PARAMETERS[name]}; give it once")
        node[last] = value
    return data


def _check_box(src, key, box):
    for a, (lo, hi) in enumerate(zip(box["min"], box["max"])):
        if not lo < hi:
            _fail(src, f"{key}.max", f"must exceed {key}.min on axis {a} ({hi} <= {lo})")


# --------------------------------------------------------------------------------- loading
def shipped_cases():
    return sorted(p.stem for p in CASES_DIR.glob("*.toml"))


def resolve(case):
    """A TOML path, or the name of a shipped case."""
    p = Path(case)
    if p.suffix == ".toml" or p.exists():
        if not p.exists():
            raise CaseError(f"{case}: no such case file")
        return p
    if (CASES_DIR / f"{case}.toml").exists():
        return CASES_DIR / f"{case}.toml"
    raise CaseError(f"{case}: neither a case file nor a shipped case ({', '.join(shipped_cases())})")


def _num(values):
    """Numbers as a reader writes them ([0.5, 1], not [np.float64(0.5), ...])."""
    return "[" + ", ".join(f"{float(v):g}" for v in values) + "]"


def read_toml(path):
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as e:
        raise CaseError(f"{path}: not UTF-8 text (byte {e.start}); save the case file as UTF-8") from None
    except tomllib.TOMLDecodeError as e:
        raise CaseError(f"{path}: not valid TOML: {e}") from None
    except OSError as e:
        raise CaseError(f"{path}: cannot read: {e.strerror}") from None


def parse_override(text):
    """``KEY=VALUE`` with VALUE in TOML syntax (a bare word is taken as a string)."""
    if "=" not in text:
        raise CaseError(f"--set {text}: expected KEY=VALUE")
    key, raw = (s.strip() for s in text.split("=", 1))
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value


def apply_override(data, key, value, src="--set"):
    params = data.get("parameters") if isinstance(data.get("parameters"), dict) else {}
    if key.startswith("parameters."):
        name = key.split(".", 1)[1]
        if name not in SPEC_PARAMETERS:
            raise CaseError(f"{src}: {key}: unknown parameter")
        data.setdefault("parameters", {})[name] = value
        return
    for name, dotted in SPEC_PARAMETERS.items():
        if dotted == key and name in params:  # the case gives it under the spec's name
            params[name] = value
            return
    parts = key.split(".")
    node, schema = data, SCHEMA
    for k, part in enumerate(parts):
        entry = schema.get(part) if isinstance(schema, dict) else None
        if entry is None:
            raise CaseError(f"{src}: {key}: " + (f"renamed: write {RENAMED[key]}" if key in RENAMED else "unknown key"))
        if k == len(parts) - 1:
            node[part] = value
        else:
            if not isinstance(entry[0], dict):
                raise CaseError(f"{src}: {key}: {'.'.join(parts[:k + 1])} has no sub-keys")
            node = node.setdefault(part, {})
            schema = entry[0]


def load(case, overrides=()):
    """Load a case by path or shipped name, apply ``KEY=VALUE`` overrides, validate."""
    path = resolve(case)
    data = read_toml(path)
    for key, value in overrides:
        apply_override(data, key, value)
    return validate(data, src=str(path))
