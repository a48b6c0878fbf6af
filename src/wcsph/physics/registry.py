"""The plug-in slots of the model and the choices registered in each.

A **slot** is one plug-in point (kernel, EOS, density formulation, pressure gradient,
diffusive term, viscous term, velocity smoothing, kernel correction, particle shifting,
collision correction, wall model). It is chosen by one key of ``[model]`` and has one
default per model preset (``model.name``: ``classic`` = Becker & Teschner with Akinci
walls, ``bi`` = the WCSPH-BI model of TNL-SPH).

A **choice** declares everything the rest of the code needs to know about it:

* ``name``: the value a case file gives (the spec's name where the spec has one);
* ``ref``: the paper or spec line its formula follows (the docs' table prints it);
* ``params``: its parameters (``Param``: key, default, unit, check, the case table);
* ``values(q)``: how those parameters (and the case quantities ``q``) enter ``P``, the
  parameter tuple of the compiled loops: a dict of P fields;
* ``build``: the factory of its compiled pieces, called by the model with a ``Ctx``;
* ``walls``: the wall models it works with; ``requires``: other slots' choices it needs;
* ``implies``: what the model must provide for it, from ``IMPLIES`` (a rate of density, the
  CSPM matrix, per-particle sound speed or p/rho^2, the wall particles' volume and density);
  the model reads these flags, never a choice's name;
* ``nu(q)``: the kinematic viscosity its term acts with, for the viscous time-step limit
  0.125 h^2 / nu (Morris et al. 1997); None when it limits nothing;
* ``passes(ctx, q)``: the passes it adds beyond its terms, each of a kind that says when it
  runs (``physics``: ``WallVolume`` at the start, ``WallPass`` and ``FluidPass`` before each
  interaction, ``AfterStepPass`` and ``WallCorrection`` after each step), with the fields
  they write; the model runs what the selection declares, in slot order;
* wall models only: ``wall_fields``, the (name, kind) fields the wall set holds, and
  ``wall_reads``, those the fluid's wall terms read: {None: always, flag: when the selection
  implies ``flag``} (the wall view follows from them and the wall passes' fields).

``config`` builds the ``[model]`` schema from these declarations, ``models.wcsph`` builds the
passes from them, and the README's slot table and every error message name them. Adding a
term is a function in its family's file plus one ``add()`` there; nothing else changes.
"""
from dataclasses import dataclass, field
from typing import Callable

REQUIRED = object()

#: the flags a choice may declare in ``implies``
IMPLIES = {
    "continuity": "rho is a state advanced by the integrator from its rate drhodt",
    "corrected": "the kernel-gradient correction matrix L of every particle",
    "sound": "each particle's sound speed c, for a pair term",
    "pr": "each particle's p / rho^2, for the m_j (p_i/rho_i^2 + p_j/rho_j^2) forms",
    "wall_volume": "the boundary particles' volume V and density rho (not only Psi)",
    "stress": "each particle's sub-particle-scale stress tensor tau (a pass before each interaction writes it)",
    "speed": "the largest fluid speed of the step before (P.vmax), so a GPU run reads its check every step",
}
POS = (lambda v: v > 0, "must be positive")
NONNEG = (lambda v: v >= 0, "must be zero or positive")
UNIT = (lambda v: 0 <= v <= 1, "must lie in [0, 1]")
UNIT_OPEN = (lambda v: 0 <= v < 1, "must lie in [0, 1)")


def one_of(*opts):
    return (lambda v: v in opts, "must be one of " + ", ".join(repr(o) for o in opts))


@dataclass(frozen=True)
class Param:
    """A parameter a choice owns. ``key`` is its name in the case table ``table``."""

    key: str
    default: object
    doc: str
    unit: str = "-"
    kind: str = "float"
    check: tuple = None  # (predicate, message), as in config's schema
    table: str = "model"
    spec: bool = False  # a runtime parameter of the WCSPH-BI spec (accepted in [parameters])
    walls: tuple = None  # the boundary kinds it applies to, when fewer than its choice's

    @property
    def dotted(self):
        return f"{self.table}.{self.key}"


@dataclass
class Choice:
    """One option of a slot; see the module docstring."""

    name: str
    ref: str
    doc: str = ""
    params: tuple = ()
    values: Callable = None  # q -> {P field: value}
    #: q -> {P field: (c, power)} for fields that depend on dt: c dt (power 1) or c / dt (-1)
    #: (``slots.step_value``; a device that sizes the step makes them too)
    step_values: Callable = None
    p_fields: tuple = ()  # the P fields ``values`` and ``step_values`` fill
    build: Callable = None
    walls: tuple = ("particles", "elements")
    requires: dict = field(default_factory=dict)  # slot -> tuple of allowed choice names
    check: Callable = None  # model table -> (key, message) of a bad combination of its values, or None
    nu: Callable = None  # q -> the kinematic viscosity its term acts with: the viscous time-step limit
    implies: frozenset = frozenset()  # what the model provides for it (see IMPLIES)
    passes: Callable = None  # (ctx, q) -> [WallVolume | WallPass | FluidPass | AfterStepPass | WallCorrection]
    wall_fields: tuple = ()  # wall models only: (name, kind) of the wall set's fields
    wall_reads: dict = field(default_factory=dict)  # wall models only: {None | flag: wall fields the terms read}
    boundary: str = None  # wall models only: "particles" or "elements"
    consistent: bool = False  # wall models only: Shepard renormalization, wall pressure interpolated
    slot: str = ""


@dataclass
class Slot:
    key: str
    title: str
    doc: str
    defaults: dict  # model preset -> default choice name
    params: tuple = ()  # parameters shared by all its choices
    choices: dict = field(default_factory=dict)

    @property
    def dotted(self):
        return f"model.{self.key}"


SLOTS = {}


def slot(name, key, title, doc, defaults, params=()):
    SLOTS[name] = Slot(key, title, doc, defaults, tuple(params))
    return SLOTS[name]


def add(slot_name, choice):
    """Register ``choice`` in slot ``slot_name`` (at import of the term's family file)."""
    s = SLOTS[slot_name]
    if not choice.implies <= IMPLIES.keys():
        raise ValueError(f"{slot_name}: {choice.name!r} implies unknown {sorted(choice.implies - IMPLIES.keys())}")
    if choice.name in s.choices:
        raise ValueError(f"{slot_name}: {choice.name!r} registered twice")
    choice.slot = slot_name
    s.choices[choice.name] = choice
    return choice


# The slots, in the order a derivative evaluation meets them. Their choices are registered by
# the physics family files (``physics/*.py``); ``slots`` imports them all.
slot("kernel", "kernel", "Kernel", "smoothing kernel W(r, h), support 2h",
     {"classic": "wendland", "bi": "wendland"})
slot("eos", "EOS", "Equation of state", "p(rho) and its inverse",
     {"classic": "TaitEquationOfState", "bi": "LinearizedColeEquationOfState"})
slot("density", "density", "Density", "how rho_i is obtained",
     {"classic": "summation", "bi": "continuity"})
slot("walls", "BCType", "Wall model", "how walls act on the fluid",
     {"classic": "AkinciBoundaryParticles", "bi": "BIConservative_numeric"})
slot("pressure", "pressure", "Pressure gradient", "the pressure term of the momentum equation",
     {"classic": "Monaghan1992", "bi": "BISymmetric"})
slot("diffusive", "DiffusiveTerm", "Diffusive term", "density diffusion in the continuity equation",
     {"classic": "None", "bi": "MolteniDiffusiveTerm"})
slot("viscous", "ViscousTerm", "Viscous term", "viscous force of the momentum equation",
     {"classic": "None", "bi": "None"})
slot("xsph", "xsph", "Velocity smoothing (XSPH)", "XSPH, on the momentum or on the positions",
     {"classic": "momentum", "bi": "None"})
slot("correction", "kernel_correction", "Kernel correction", "correction of the kernel gradient",
     {"classic": "None", "bi": "None"})
slot("shifting", "shifting", "Particle shifting", "shifting of particles in the bulk",
     {"classic": "None", "bi": "None"})
slot("collision", "collision", "Collision correction", "velocity correction of close pairs",
     {"classic": "None", "bi": "None"})
