"""Case description: a TOML file, or the same nested dict from Python.

The schema below is the single source of truth for keys, types, defaults and limits. Every
problem is reported as a ``CaseError`` naming the file and the dotted key, e.g.
``dam.toml: model.xsph: expected a number, got 'high'``.
"""
import copy
import math
import tomllib
from pathlib import Path

CASES_DIR = Path(__file__).parent / "cases"


class CaseError(ValueError):
    """A case that cannot run, with a message naming the file and key."""


# ---------------------------------------------------------------------------------- schema
# leaf: (kind, default, check) where kind is a type tag and check a (predicate, message)
REQUIRED = object()
POS = (lambda v: v > 0, "must be positive")
NONNEG = (lambda v: v >= 0, "must be zero or positive")


def _one_of(*opts):
    return (lambda v: v in opts, "must be one of " + ", ".join(repr(o) for o in opts))


BLOCK = {"min": ("vec", REQUIRED, None), "max": ("vec", REQUIRED, None)}
FLUID_BLOCK = dict(BLOCK, velocity=("vec", None, None))

SCHEMA = {
    "name": ("str", "case", None),
    "description": ("str", "", None),
    "dim": ("int", REQUIRED, _one_of(2, 3)),
    "dp": ("float", REQUIRED, POS),
    "precision": ("str", "float32", _one_of("float32", "float64")),
    "backend": ("str", "cpu", _one_of("cpu", "cuda")),
    "domain": ({"min": ("vec", None, None), "max": ("vec", None, None)}, None, None),
    "fluid": ([FLUID_BLOCK], REQUIRED, None),
    "tank": (dict(BLOCK, open_top=("bool", True, None)), None, None),
    "obstacle": ([BLOCK], [], None),
    "physics": ({
        "rho0": ("float", 1000.0, POS),
        "gravity": ("vec", None, None),
        "speed_of_sound": ("float", 0.0, NONNEG),
        "kappa": ("float", 0.0, NONNEG),
        "gamma": ("float", 7.0, POS),
        "gravity_ramp_time": ("float", 0.0, NONNEG),
    }, {}, None),
    "model": ({
        "name": ("str", "classic", _one_of("classic")),
        "kernel": ("str", "wendland", _one_of("wendland", "cubic_spline")),
        "smoothing_ratio": ("float", 2.0, POS),
        "xsph": ("float", 0.1, (lambda v: 0 <= v <= 1, "must lie in [0, 1]")),
        "wall_xsph": ("float", 0.0, (lambda v: 0 <= v <= 1, "must lie in [0, 1]")),
        "clamp_negative_pressure": ("bool", True, None),
        "wall_layers": ("int", 0, NONNEG),
        "wall_volume": ("str", "lattice", _one_of("lattice", "akinci")),
    }, {}, None),
    "time": ({
        "end": ("float", REQUIRED, POS),
        "cfl": ("float", 0.25, POS),
        "force_cfl": ("float", 0.25, POS),
        "dt": ("float", 0.0, NONNEG),
        "max_steps": ("int", 0, NONNEG),
    }, REQUIRED, None),
    "output": ({
        "interval": ("float", 0.0, NONNEG),
        "vtk": ("bool", True, None),
        "surge_front": ("bool", False, None),
        "progress": ("bool", True, None),
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
    raise AssertionError(kind)


def _validate(src, prefix, schema, data, dim):
    if not isinstance(data, dict):
        _fail(src, prefix.rstrip("."), f"expected a table, got {data!r}")
    unknown = sorted(set(data) - set(schema))
    if unknown:
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
    case = _validate(src, "", SCHEMA, data, dim)
    ph = case["physics"]
    if ph["kappa"] > 0 and ph["speed_of_sound"] > 0:
        _fail(src, "physics.kappa", "give kappa or speed_of_sound, not both (kappa = c0^2)")
    if ph["gravity"] is None:
        case["physics"]["gravity"] = [0.0] * (dim - 1) + [-9.81]
    for kind in ("fluid", "obstacle"):
        for k, b in enumerate(case[kind]):
            _check_box(src, f"{kind}[{k}]", b)
    if case["tank"] is not None:
        _check_box(src, "tank", case["tank"])
    d = case["domain"]
    if d is not None and (d["min"] is None) != (d["max"] is None):
        _fail(src, "domain", "give both min and max, or neither")
    if d is not None and d["min"] is not None:
        _check_box(src, "domain", d)
    case["_source"] = src
    return case


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


def read_toml(path):
    path = Path(path)
    try:
        return tomllib.loads(path.read_text())
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
    parts = key.split(".")
    node, schema = data, SCHEMA
    for k, part in enumerate(parts):
        entry = schema.get(part) if isinstance(schema, dict) else None
        if entry is None:
            raise CaseError(f"{src}: {key}: unknown key")
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
