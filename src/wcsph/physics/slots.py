"""Everything derived from the slot registries (``registry``): the ``[model]`` schema, the
spec's parameter names, the parameter tuple ``P`` of the compiled loops, a case's selection
and its combination checks, and the table of slots the README prints.

Importing this module imports every physics family, which registers its choices.
"""
from collections import namedtuple
from dataclasses import dataclass

import importlib
import os
import pkgutil
import sys

from . import kernels  # noqa: F401  (registers the kernels)
from .. import physics
from .registry import NONNEG, POS, SLOTS, Param, one_of

#: modules outside the package that register choices, imported after the physics families:
#: a comma-separated list of importable module names
PLUGINS_VARIABLE = "WCSPH_PLUGINS"


def _import_families():
    """Every module of ``physics/`` (each family file registers its choices on import: a new
    one needs no list to be edited), then the modules named by ``WCSPH_PLUGINS``."""
    for info in sorted(pkgutil.iter_modules(physics.__path__), key=lambda m: m.name):
        importlib.import_module(f"{physics.__name__}.{info.name}")
    for name in filter(None, (n.strip() for n in os.environ.get(PLUGINS_VARIABLE, "").split(","))):
        try:
            importlib.import_module(name)
        except Exception as e:  # a setting of the environment, not of a case: one line, then stop
            sys.exit(f"wcsph: {PLUGINS_VARIABLE}: cannot import the plug-in module {name!r}: {e}")


_import_families()

PRESETS = ("classic", "bi")

#: model parameters that belong to no slot
BASE_PARAMS = (
    Param("mass", 0.0, "fluid particle mass; 0: rho0 dp^dim (continuity density) or the mass that makes the "
          "initial lattice's summation density rho0 (summation density)", unit="kg", check=NONNEG, spec=True),
    Param("eps", 0.001, "eps of the eps h^2 regularisation (eta^2 of the third spec)", check=POS, spec=True),
)

#: P fields every model has (kernel, reference state, body force, step)
BASE_FIELDS = ("rc2", "h_inv", "w_norm", "g_norm", "rho0", "rho0_inv", "c0", "c2", "p0", "gx", "gy", "gz", "dt",
               "eps_h2", "vmax")


def _choice_fields():
    seen = []
    for s in SLOTS.values():
        for c in s.choices.values():
            for f in c.p_fields:
                if f not in seen and f not in BASE_FIELDS:
                    seen.append(f)
    return tuple(seen)


#: the parameter tuple of every compiled loop: the base fields and every choice's fields (a
#: field no selected choice fills is 0). One type for every case, so one compiled loop each.
Params = namedtuple("Params", BASE_FIELDS + _choice_fields())


# ------------------------------------------------------------------------------ schema
def params():
    """{dotted key: (Param, [the choices that own it])}; base and slot parameters have no
    owning choice (an empty list)."""
    out = {p.dotted: (p, []) for p in BASE_PARAMS}
    for s in SLOTS.values():
        for p in s.params:
            out.setdefault(p.dotted, (p, []))
        for c in s.choices.values():
            for p in c.params:
                prev = out.setdefault(p.dotted, (p, []))
                if prev[0] != p:
                    raise ValueError(f"{p.dotted} declared twice with different settings")
                prev[1].append(c)
    return out


def model_schema():
    """The ``[model]`` table of the case schema: name, one key per slot (default: the
    preset's, filled in by ``resolve``), and every parameter."""
    schema = {"name": ("str", "classic", one_of(*PRESETS))}
    for s in SLOTS.values():
        schema[s.key] = ("str", None, one_of(*s.choices))
    for p, _ in params().values():
        if p.table == "model":
            schema[p.key] = (p.kind, p.default, p.check)
    return schema


def physics_params():
    """Parameters that choices declare in ``[physics]`` (e.g. gamma)."""
    return {p.key: (p.kind, p.default, p.check) for p, _ in params().values() if p.table == "physics"}


def spec_parameters():
    """The spec's runtime parameter names of choices, and where each lives in the case."""
    return {p.key: p.dotted for p, _ in params().values() if p.spec}


# ------------------------------------------------------------------------------ a case
def resolve(model):
    """Fill each slot left out with its preset's default (in place)."""
    for s in SLOTS.values():
        if model.get(s.key) is None:
            model[s.key] = s.defaults[model["name"]]


def selection(model):
    """{slot name: Choice} of a resolved model table."""
    return {name: s.choices[model[s.key]] for name, s in SLOTS.items()}


def problems(model, given):
    """Bad combinations in a resolved model table: (key, message) errors, then warnings.
    ``given``: the keys the case file set (a parameter nobody reads is worth a warning)."""
    sel = selection(model)
    wall = sel["walls"]
    errors, warnings = [], []
    for name, c in sel.items():
        key = SLOTS[name].dotted
        if wall.boundary not in c.walls:
            errors.append((key, f"{c.name!r} needs {'boundary particles' if 'particles' in c.walls else 'boundary elements'}"
                           f", which model.BCType = {wall.name!r} does not give"))
        for other, allowed in c.requires.items():
            if sel[other].name not in allowed:
                errors.append((key, f"{c.name!r} needs {SLOTS[other].dotted} = "
                               + " or ".join(repr(a) for a in allowed) + f", not {sel[other].name!r}"))
        if c.check is not None:
            bad = c.check(model)
            if bad:
                errors.append((f"model.{bad[0]}", bad[1]))
    used = {p.key for p in BASE_PARAMS}
    for name, c in sel.items():
        used.update(p.key for p in SLOTS[name].params)
        used.update(p.key for p in c.params if p.walls is None or wall.boundary in p.walls)
    for dotted, (p, owners) in params().items():
        if p.table != "model" or p.key not in given or p.key in used:
            continue
        where = " or ".join(f"{SLOTS[c.slot].dotted} = {c.name!r}" for c in owners)
        if all(wall.boundary not in (p.walls or c.walls) for c in owners):
            errors.append((dotted, f"applies to {where}, not to model.BCType = {wall.name!r}"))
        else:
            warnings.append(f"{dotted} is set but has no effect: it belongs to {where}")
    return errors, warnings


@dataclass
class Quantities:
    """What a choice's ``values`` may read: the case's model and physics tables and the
    quantities the set-up derives."""

    m: dict
    ph: dict
    dim: int
    dp: float
    h: float
    c0: float
    rho0: float
    kernel: dict  # rc, h_inv, w_norm, g_norm
    kernel_numpy: object  # W(r) in NumPy, for values that need a kernel value
    boundary: str = "particles"
    conservative: bool = True
    corrected: bool = False
    continuity: bool = True
    sound: object = None  # jitable c(rho, P) of the EOS (set by the model)
    eos_density: object = None  # jitable rho(p, P) of the EOS
    noslip: bool = False  # a wall pass makes the no-slip velocity v_ext the viscous terms read (set by the model)


def make_params(dtype, q, sel, gravity, dt=1.0):
    """``P`` for the selection ``sel``: base fields, then each choice's values."""
    g = list(gravity) + [0.0] * (3 - len(gravity))
    k = q.kernel
    v = dict.fromkeys(Params._fields, 0.0)
    v.update(rc2=k["rc"] ** 2, h_inv=k["h_inv"], w_norm=k["w_norm"], g_norm=k["g_norm"], rho0=q.rho0,
             rho0_inv=1.0 / q.rho0, c0=q.c0, c2=q.c0 ** 2, p0=q.ph["p0"], gx=g[0], gy=g[1], gz=g[2], dt=dt,
             eps_h2=q.m["eps"] * q.h * q.h, vmax=0.0)
    for c in sel.values():
        if c.values is not None:
            v.update(c.values(q))
        if c.step_values is not None:
            v.update({f: step_value(k, power, dt) for f, (k, power) in c.step_values(q).items()})
    return Params(**{f: dtype(x) for f, x in v.items()})


def step_value(c, power, dt):
    """A P field that depends on the step's size: c dt (``power`` 1) or c / dt (-1). Jitable:
    the host's and a device's (``stepped_values``) are this one function."""
    return c / dt if power < 0 else c * dt


def stepped_values(q, stepped):
    """(P field, c, power) of every field the choices ``stepped`` make from dt."""
    return tuple((f, float(k), int(power)) for c in stepped for f, (k, power) in c.step_values(q).items())


def update_params(P, dtype, q, stepped, dt, gravity, vmax):
    """P for a step of size ``dt`` under body force ``gravity``, fluid speeds up to ``vmax``;
    ``stepped``: the selected choices with ``step_values``."""
    v = {"dt": dtype(dt), "gx": dtype(gravity[0]), "gy": dtype(gravity[1]),
         "gz": dtype(gravity[2] if len(gravity) == 3 else 0.0), "vmax": dtype(vmax)}
    for c in stepped:
        for f, (k, power) in c.step_values(q).items():
            v[f] = dtype(step_value(k, power, dt))
    return P._replace(**v)


# ------------------------------------------------------------------------------ docs
def slot_table():
    """Markdown: every slot, its key, its choices with the reference each follows, the
    presets' defaults and the choice's parameters."""
    rows = ["| slot | key | choice | follows | parameters (default) |", "|---|---|---|---|---|"]
    for name, s in SLOTS.items():
        for c in s.choices.values():
            dflt = [p for p in PRESETS if s.defaults[p] == c.name]
            choice = f"`{c.name}`" + (f" ({', '.join(dflt)} default)" if dflt else "")
            ps = ", ".join(f"`{p.key}` ({p.default!r})" for p in c.params)
            rows.append(f"| {s.title} | `{s.dotted}` | {choice} | {c.ref} | {ps} |")
    return "\n".join(rows)


__all__ = ["Params", "model_schema", "physics_params", "spec_parameters", "resolve", "selection", "problems",
           "Quantities", "make_params", "update_params", "slot_table"]
