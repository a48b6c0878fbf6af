"""Time integrators, independent of the model.

An integrator sees a particle set through ``StateView``: the state (x, v and, for models with
a continuity equation, rho), the derivatives the model last wrote (dvdt, drhodt), p and m
(for the energy residual), and its own arrays (x_n v_n rho_n: the state at the start of the step; dv_t drho_t: the
implicit midpoint's iterated derivatives; k: Runge-Kutta stages; w: per-stage
coefficients). A step gets the run state (``solver.state.State``): it calls ``state.evaluate(P, at)``
for the derivatives at the current state, which is that of time t + at dt (moving walls are
placed at that time), ``state.view(w)`` for the particles as the maps see
them, and ``state.reduce(map, view, P)`` for a reduction map (over every process's particles
in a decomposed run).
A model without a continuity equation (density by summation) has ``continuity = False``; the
integrator then leaves rho alone.

Each scheme is a few per-particle maps (jitable functions of (i, I, P), compiled by the
backend) and a ``step`` that strings them together with derivative evaluations. ``step``
returns the time step it took (an adaptive scheme may take less than it was offered).
"""
import math
from collections import namedtuple

import numpy as np
from numba.extending import register_jitable

from ..errors import IntegrationError
from .registry import NONNEG, POS, UNIT_OPEN, Param, one_of

StateView = namedtuple("StateView", "x v dvdt rho drhodt p m x_n v_n rho_n dv_t drho_t k w")
#: the saved-state arrays, where the predictor run in a pass's loop writes (``make_predict_aside``)
AsideView = namedtuple("AsideView", "x_n v_n rho_n")


# ------------------------------------------------------------------------------ shared
def make_copy_state(dim, continuity, to_saved):
    """x_n, v_n, rho_n <- x, v, rho (``to_saved``), or back."""

    @register_jitable
    def copy(i, I, P):
        for d in range(dim):
            if to_saved:
                I.x_n[d, i] = I.x[d, i]
                I.v_n[d, i] = I.v[d, i]
            else:
                I.x[d, i] = I.x_n[d, i]
                I.v[d, i] = I.v_n[d, i]
        if continuity:
            if to_saved:
                I.rho_n[i] = I.rho[i]
            else:
                I.rho[i] = I.rho_n[i]

    return copy


# ------------------------------------------------------------------------------ explicit
def make_symplectic_euler(dim, continuity, dtype):
    """Semi-implicit (symplectic) Euler of Becker & Teschner (2007), first order:
    v(t+dt) = v(t) + dt a(t);  x(t+dt) = x(t) + dt v(t+dt);  rho += dt Drho/Dt."""

    @register_jitable
    def advance(i, I, P):
        for d in range(dim):
            I.v[d, i] += P.dt * I.dvdt[d, i]
            I.x[d, i] += P.dt * I.v[d, i]
        if continuity:
            I.rho[i] += P.dt * I.drhodt[i]

    return (advance,)


def make_verlet(dim, continuity, dtype):
    """Verlet of Monaghan (1989), the DualSPHysics "Verlet" scheme (Crespo et al. 2015):
    x_n+1 = x_n + dt v_n + dt^2/2 a_n,  v_n+1 = v_n-1 + 2 dt a_n,  rho_n+1 = rho_n-1 + 2 dt Drho_n.
    The spec prints x_n-1 in the position update; x_n is the scheme (a step from n-1 with
    dt would be first order). ``euler`` is the stabilizing step every f_ES steps:
    v_n+1 = v_n + dt a_n, rho_n+1 = rho_n + dt Drho_n (position as above). v_n, rho_n hold the
    previous step's v and rho."""
    half, two = dtype(0.5), dtype(2)

    @register_jitable
    def leapfrog(i, I, P):
        dt = P.dt
        for d in range(dim):
            v = I.v[d, i]
            I.x[d, i] += dt * v + half * dt * dt * I.dvdt[d, i]
            I.v[d, i] = I.v_n[d, i] + two * dt * I.dvdt[d, i]
            I.v_n[d, i] = v
        if continuity:
            rho = I.rho[i]
            I.rho[i] = I.rho_n[i] + two * dt * I.drhodt[i]
            I.rho_n[i] = rho

    @register_jitable
    def euler(i, I, P):
        dt = P.dt
        for d in range(dim):
            v = I.v[d, i]
            I.x[d, i] += dt * v + half * dt * dt * I.dvdt[d, i]
            I.v[d, i] = v + dt * I.dvdt[d, i]
            I.v_n[d, i] = v
        if continuity:
            rho = I.rho[i]
            I.rho[i] = rho + dt * I.drhodt[i]
            I.rho_n[i] = rho

    return leapfrog, euler


def make_symplectic_verlet(dim, continuity, dtype):
    """Symplectic position Verlet, predictor-corrector (Leimkuhler, Reich & Skeel 1996;
    the DualSPHysics "Symplectic" scheme), as the spec writes it with two slips corrected:
    predictor  x' = x_n + dt/2 v_n, v' = v_n + dt/2 a_n, rho' = rho_n + dt/2 Drho_n;
    corrector  v_n+1 = v_n + dt a', x_n+1 = x_n + dt (v_n + v_n+1)/2,
               rho_n+1 = rho_n (2 - e)/(2 + e), e = -Drho'/rho' dt (Monaghan 2005: exact for
               a uniform compression, keeps rho > 0)."""
    half, two = dtype(0.5), dtype(2)

    @register_jitable
    def predict(i, I, P):
        h = P.dt * half
        for d in range(dim):
            I.x_n[d, i] = I.x[d, i]
            I.v_n[d, i] = I.v[d, i]
            I.x[d, i] += h * I.v[d, i]
            I.v[d, i] += h * I.dvdt[d, i]
        if continuity:
            I.rho_n[i] = I.rho[i]
            I.rho[i] += h * I.drhodt[i]

    @register_jitable
    def correct(i, I, P):
        h = P.dt * half
        for d in range(dim):
            v1 = I.v_n[d, i] + P.dt * I.dvdt[d, i]
            I.x[d, i] = I.x_n[d, i] + h * (I.v_n[d, i] + v1)
            I.v[d, i] = v1
        if continuity:
            e = -I.drhodt[i] / I.rho[i] * P.dt
            I.rho[i] = I.rho_n[i] * (two - e) / (two + e)

    return predict, correct


def make_predict_aside(dim, continuity, dtype):
    """The symplectic Verlet predictor writing the predicted state into the saved-state arrays
    (``A``, an ``AsideView``), x_n <- x + dt/2 v, v_n <- v + dt/2 a, rho_n <- rho + dt/2 Drho,
    with x, v, a, rho and Drho read from the pass's own view I and left as they are: what the
    loop of a pass can run while its other particles still read x, v and rho; the arrays then
    swap names (``SymplecticVerlet.fuse_first``), which gives the
    predictor's state with the same arithmetic."""
    half = dtype(0.5)

    @register_jitable
    def predict_aside(i, I, A, P):
        h = P.dt * half
        for d in range(dim):
            A.x_n[d, i] = I.x[d, i] + h * I.v[d, i]
            A.v_n[d, i] = I.v[d, i] + h * I.dvdt[d, i]
        if continuity:
            A.rho_n[i] = I.rho[i] + h * I.drhodt[i]

    return predict_aside


def make_runge_kutta(stages):
    """Maps of an explicit Runge-Kutta scheme with ``stages`` stages, for any tableau: the
    coefficients come at run time in ``I.w``. ``k[s]`` holds stage s's derivative of the
    whole state: components 0..dim-1 dx/dt (= v), dim..2dim-1 dv/dt, 2dim Drho/Dt.

    ``stage``: store the current derivatives as k[s] (s = w[S]), then set the state to
    y0 + dt sum_j w[j] k[j] (the next stage's argument, or with w = b the step's result).
    ``error``: the scaled local error dt |sum_j w[j] k[j]| with w = b - b_hat, as
    max(|e_x| w[S+1], |e_v| w[S+2], |e_rho| w[S+3]) (returned as the max of the reduction).
    """

    def factory(dim, continuity, dtype):
        S = stages
        zero = dtype(0)

        @register_jitable
        def stage(i, I, P):
            s = int(I.w[S])
            for d in range(dim):
                I.k[s, d, i] = I.v[d, i]
                I.k[s, dim + d, i] = I.dvdt[d, i]
            if continuity:
                I.k[s, 2 * dim, i] = I.drhodt[i]
            for d in range(dim):
                sx = zero
                sv = zero
                for j in range(S):
                    if I.w[j] != zero:
                        sx += I.w[j] * I.k[j, d, i]
                        sv += I.w[j] * I.k[j, dim + d, i]
                I.x[d, i] = I.x_n[d, i] + P.dt * sx
                I.v[d, i] = I.v_n[d, i] + P.dt * sv
            if continuity:
                sr = zero
                for j in range(S):
                    if I.w[j] != zero:
                        sr += I.w[j] * I.k[j, 2 * dim, i]
                I.rho[i] = I.rho_n[i] + P.dt * sr

        @register_jitable
        def error(i, I, P):
            ex = zero
            ev = zero
            for d in range(dim):
                sx = zero
                sv = zero
                for j in range(S):
                    sx += I.w[j] * I.k[j, d, i]
                    sv += I.w[j] * I.k[j, dim + d, i]
                ex += sx * sx
                ev += sv * sv
            e = max(math.sqrt(ex) * I.w[S + 1], math.sqrt(ev) * I.w[S + 2])
            if continuity:
                sr = zero
                for j in range(S):
                    sr += I.w[j] * I.k[j, 2 * dim, i]
                e = max(e, abs(sr) * I.w[S + 3])
            return zero, zero, P.dt * e

        return (make_copy_state(dim, continuity, True), stage, make_copy_state(dim, continuity, False), error)

    return factory


# ------------------------------------------------------------------------------ implicit
def make_midpoint(dim, continuity, dtype):
    """Maps of the implicit midpoint scheme (see ``ImplicitMidpoint``). x_n, v_n, rho_n: the
    state at t_n; dv_t, drho_t: the iterated midpoint derivatives (tilde v, tilde rho of the
    spec); w[0]: the relaxation weight of the previous iterate."""
    half, one = dtype(0.5), dtype(1)

    @register_jitable
    def guess(i, I, P):
        for d in range(dim):
            I.dv_t[d, i] = I.dvdt[d, i]
        if continuity:
            I.drho_t[i] = I.drhodt[i]

    @register_jitable
    def midstate(i, I, P):
        h = P.dt * half
        for d in range(dim):
            v = I.v_n[d, i] + h * I.dv_t[d, i]
            I.v[d, i] = v
            I.x[d, i] = I.x_n[d, i] + h * v
        if continuity:
            I.rho[i] = I.rho_n[i] + h * I.drho_t[i]

    @register_jitable
    def residual(i, I, P):
        """(|m v.(a - a~)| + |m p/rho^2 (Drho - rho~)|, |m v.a| + |m p/rho^2 Drho|, 0) at the
        midpoint: the change of the energy rate since the last iterate, and its size."""
        dk = dtype(0)
        k = dtype(0)
        for d in range(dim):
            dk += I.v[d, i] * (I.dvdt[d, i] - I.dv_t[d, i])
            k += I.v[d, i] * I.dvdt[d, i]
        r = abs(dk)
        s = abs(k)
        if continuity:
            c = I.p[i] / (I.rho[i] * I.rho[i])
            r += abs(c * (I.drhodt[i] - I.drho_t[i]))
            s += abs(c * I.drhodt[i])
        return I.m[i] * r, I.m[i] * s, dtype(0)

    @register_jitable
    def relax(i, I, P):
        om = I.w[0]
        for d in range(dim):
            I.dv_t[d, i] = (one - om) * I.dvdt[d, i] + om * I.dv_t[d, i]
        if continuity:
            I.drho_t[i] = (one - om) * I.drhodt[i] + om * I.drho_t[i]

    @register_jitable
    def finish(i, I, P):
        for d in range(dim):
            v = I.v_n[d, i] + P.dt * I.dv_t[d, i]
            I.x[d, i] = I.x_n[d, i] + P.dt * half * (I.v_n[d, i] + v)
            I.v[d, i] = v
        if continuity:
            I.rho[i] = I.rho_n[i] + P.dt * I.drho_t[i]

    return make_copy_state(dim, continuity, True), guess, midstate, residual, relax, finish


# ------------------------------------------------------------------------------ schemes
_SAVED = (("x_n", "vector", True), ("v_n", "vector", True), ("rho_n", "scalar", True))


#: the registered schemes, by name (``register``); ``[time]`` is built from their declarations
INTEGRATORS = {}
#: the spec's IntegrationScheme names, to the registered names
SPEC_SCHEMES = {}


def register(cls):
    """Register an integrator class: it declares its ``name``, the spec's name for it
    (``spec_name``, or None), the reference it follows (``ref``) and its ``[time]``
    parameters (``params``). A new scheme is a class plus this decorator."""
    if cls.name in INTEGRATORS or (cls.spec_name and cls.spec_name in SPEC_SCHEMES):
        raise ValueError(f"integrator {cls.name!r} registered twice")
    INTEGRATORS[cls.name] = cls
    if cls.spec_name:
        SPEC_SCHEMES[cls.spec_name] = cls.name
    return cls


class Integrator:
    """A scheme as a sequence of derivative evaluations and per-particle maps."""

    name = None  # its value of ``time.integrator``
    spec_name = None  # the spec's IntegrationScheme name for it, if the spec has it
    ref = ""  # the paper its update follows
    params = ()  # its parameters (``Param`` in the ``[time]`` table); the settings it reads
    fields = ()  # per-particle arrays the scheme keeps: (name, kind, scratch)
    order = None  # formal order of accuracy
    evaluations = 1  # derivative evaluations per step (per iteration when ``iterated``)
    iterated = False  # an implicit scheme: its evaluations repeat per iteration
    reduce_maps = ()  # indices of the maps that are reductions, not per-particle updates
    #: scalar attributes that carry from one step to the next (saved in checkpoints)
    carried = ()
    #: the largest cfl that ran dam_break_2d_bi to 1 s (benchmarks/integrators.py; None: the
    #: scheme's error control sets the step), and the default when time.cfl is not given:
    #: about half of it, for a continuity-density model; ``summation_cfl`` for the classic
    #: model's density summation, where symplectic Euler is stable at 0.25
    stable_cfl = None
    safe_cfl = 0.25
    summation_cfl = None

    #: indices of the maps that a derivative evaluation follows: each may run the model's
    #: refresh of p and V in its own loop (``fuse_refresh``)
    refreshing = ()
    #: indices of the maps that end a step (nothing of the scheme follows them): each may run
    #: the model's wall corrections and the run's check in its own loop (``fuse_tail``)
    ending = ()
    #: the step starts with a derivative evaluation (no map before it): the p and V of the
    #: step's start may then be made by the sort (``solver.sort``)
    opens_with_evaluation = False
    #: the scheme takes the step the stability conditions offer as it is and reads nothing of
    #: the device within it, so a device may make the step's size (``solver.timestep``)
    takes_stable_step = True

    def __init__(self, backend, dim, continuity, dtype, settings=None):
        self.backend, self.dim, self.continuity, self.dtype = backend, dim, continuity, dtype
        self.settings = settings or {}
        self.fns = self.factory(dim, continuity, dtype)
        self.maps = [backend.make_reduce(f) if k in self.reduce_maps else backend.make_map(f)
                     for k, f in enumerate(self.fns)]
        self.fused = {}  # map index -> the map with the model's refresh in its loop
        self.tails = {}  # map index -> the map with the wall corrections and the check in its loop
        self.stats = {}  # per-step figures for the log (iterations, residual, ...)

    def fuse_refresh(self, refresh_fn):
        """Run the model's ``refresh_fn`` (p and V from rho, a continuity-density model's
        first map of an evaluation) in the loop of each map of ``refreshing``, with the
        density the map wrote, so that the evaluation after it starts with the walls: one
        launch fewer per such map on a GPU, and the same numbers. Not for a decomposed run,
        whose evaluation first refreshes the ghosts' rho from their owners."""
        self.fused = {k: self.backend.make_map(self.fns[k], then=refresh_fn) for k in self.refreshing}

    def fuse_tail(self, walk, walk_pass=None):
        """Make each map of ``ending`` a tail (``backend.make_tail``): the map, then in its
        loop the model's wall corrections ``walk`` = (init, pair, store) (or none; compiled
        as a pass: ``walk_pass``) and, on a backend that fuses it, the run's check.
        ``end_step`` runs it when the run state allows (``State.tail``): one launch or two
        fewer per step on a GPU, the same numbers."""
        self.tails = {k: self.backend.make_tail(self.dim, self.dtype, self.fns[k], walk, (self.maps[k], walk_pass))
                      for k in self.ending}

    def end_step(self, state, k, P):
        """Map ``k``, the step's last: as the tail with what the run state asks this step
        (``State.tail``), else alone."""
        tail = self.tails.get(k) if self.tails else None
        args = state.tail() if tail is not None else None
        if args is None:
            self.maps[k](state.view(), P)
        else:
            tail(state.view(), P, *args)

    def fuse_first(self, model, fluid):
        """Run a map in the loop of the first evaluation's last pass, where the scheme has one
        (``SymplecticVerlet``): nothing here."""

    def map_then_evaluate(self, state, k, P, at, w=None):
        """Map ``k`` over the fluid (with the per-stage coefficients ``w``), then the
        derivatives at time t + ``at`` dt."""
        view = state.view(w)
        if k in self.fused:
            self.fused[k](view, P, state.refresh_view())
            state.evaluate(P, at=at, refreshed=True)
        else:
            self.maps[k](view, P)
            state.evaluate(P, at=at)

    def setting(self, key):
        """Its parameter ``key`` from the ``[time]`` settings, else the parameter's default."""
        default = next(p.default for p in self.params if p.key == key)
        return self.settings.get(key, default)

    def propose(self, dt):
        """The step the scheme wants, given the one the stability conditions allow."""
        return dt

    def columns(self):
        return list(self.stats)

    def default_cfl(self):
        """The cfl this scheme starts from when the case gives none."""
        return self.summation_cfl if not self.continuity and self.summation_cfl else self.safe_cfl

    def carried_state(self):
        """The scheme's scalars a restart needs, and its last per-step figures."""
        return {"carried": {k: getattr(self, k) for k in self.carried}, "stats": dict(self.stats)}

    def restore(self, state):
        for k, v in state["carried"].items():
            setattr(self, k, v)
        self.stats = dict(state["stats"])


@register
class SymplecticEuler(Integrator):
    name, spec_name, ref = 'symplectic_euler', None, 'Becker & Teschner (2007)'
    factory = staticmethod(make_symplectic_euler)
    order = 1
    stable_cfl, safe_cfl, summation_cfl = 0.05, 0.025, 0.25
    opens_with_evaluation = True
    ending = (0,)

    def step(self, state, P):
        state.evaluate(P)
        self.end_step(state, 0, P)
        return float(P.dt)


@register
class Verlet(Integrator):
    """Verlet with an explicit Euler step every ``verlet_euler_interval`` steps (f_ES, 40 by
    default; 0: only the first step). v and rho of the previous step travel with the
    particles, so they are not scratch."""
    name, spec_name, ref = 'verlet', 'VerletScheme', 'Monaghan (1989); Crespo et al. (2015)'
    params = (Param("verlet_euler_interval", 40, "steps between Verlet's explicit Euler steps (0: never)", kind="int",
                    check=NONNEG, table="time"),)
    factory = staticmethod(make_verlet)
    fields = (("v_n", "vector", False), ("rho_n", "scalar", False))
    order = 2
    stable_cfl, safe_cfl = 0.1, 0.05
    carried = ("count",)
    opens_with_evaluation = True
    ending = (0, 1)  # leapfrog, Euler

    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        self.every = int(self.setting("verlet_euler_interval"))
        self.count = 0

    def step(self, state, P):
        state.evaluate(P)
        first = self.count == 0 or (self.every > 0 and self.count % self.every == 0)
        self.end_step(state, 1 if first else 0, P)
        self.count += 1
        return float(P.dt)


@register
class SymplecticVerlet(Integrator):
    name, spec_name, ref = 'symplectic_verlet', 'SymplecticVerletScheme', 'Leimkuhler, Reich & Skeel (1996)'
    factory = staticmethod(make_symplectic_verlet)
    fields = _SAVED
    order = 2
    stable_cfl, safe_cfl = 0.4, 0.25
    evaluations = 2
    refreshing = (0,)  # the predictor
    opens_with_evaluation = True
    ending = (1,)  # the corrector
    first = None  # the first evaluation's last pass with the predictor in its loop (``fuse_first``)

    def fuse_first(self, model, fluid):
        """The predictor, with the model's EOS of the predicted density, in the loop of the
        first evaluation's interaction pass, after each particle's derivatives: one launch
        fewer a step on a GPU (the CPU runs it as a loop of its own after the pass). It
        writes the predicted state beside the state the pass reads (``make_predict_aside``;
        p and V of the predicted density into spare arrays, which ``fluid`` gets here), and
        the arrays swap names after the pass (``State.swap``): the same numbers. For a
        continuity density, in a run of one process."""
        if not self.continuity or model.refresh_fn is None:
            return
        aside = make_predict_aside(self.dim, self.continuity, self.dtype)
        refresh = model.refresh_fn

        @register_jitable
        def predict(i, I, A, R, P):
            aside(i, I, A, P)
            refresh(i, R, P, A.rho_n[i])

        self.first = model.interaction_then(predict)
        self.swapped = (("x", "x_n"), ("v", "v_n"), ("rho", "rho_n")) + model.add_spares(fluid)

    def step(self, state, P):
        if self.first is None:
            state.evaluate(P)
            self.map_then_evaluate(state, 0, P, at=0.5)
        else:
            f = state.fluid
            state.evaluate(P, then=(self.first, AsideView(f["x_n"], f["v_n"], f["rho_n"]),
                                    state.model.spare_view(f)))
            state.swap(self.swapped)
            state.evaluate(P, at=0.5, refreshed=True)
        self.end_step(state, 1, P)
        return float(P.dt)


class RungeKutta(Integrator):
    """An explicit Runge-Kutta scheme given by its Butcher tableau (A, b, b_hat). With b_hat
    (an embedded pair) and a variable time step, the step is chosen by local error control
    (Hairer, Norsett & Wanner, Solving ODEs I, II.4): the error estimate
    e = dt sum (b - b_hat)_j k_j is scaled per particle by h for positions, c0 for velocities
    and rho0 for density (the acoustic scales: rho'/rho0 ~ v'/c0), its maximum over
    particles err is held at ``rk45_tolerance``: a step with err > tol is redone with a
    smaller dt, and the next step is dt (tol/err)^(1/5) x 0.9, within 0.2x..5x. The
    stability conditions (CFL, force, viscous) still bound the step from above. The higher
    order solution is propagated (local extrapolation, as in Dormand & Prince 1980)."""

    A = b = b_hat = None
    carried = ("dt_next",)
    refreshing = (0, 1)  # the save before the first evaluation, each stage before the next

    def __init__(self, backend, dim, continuity, dtype, settings=None):
        self.factory = make_runge_kutta(len(self.b))
        self.reduce_maps = (3,)
        super().__init__(backend, dim, continuity, dtype, settings)
        S = len(self.b)
        self.fields = _SAVED + (("k", (S, 2 * dim + 1), True),)
        self.stage_w = []
        for s in range(S):
            row = list(self.A[s + 1]) if s + 1 < S else list(self.b)
            self.stage_w.append(self._weights(row, s))
        self.err_w = None
        self.tol = float(self.setting("rk45_tolerance")) if self.b_hat is not None else 0.0
        self.adaptive = self.b_hat is not None and self.settings.get("adaptive", True)
        self.dt_next = None
        if self.b_hat is not None:
            self.stats = {"rk_error": 0.0, "rk_rejected": 0}

    def _weights(self, row, s, scales=(0.0, 0.0, 0.0)):
        S = len(self.b)
        w = np.zeros(S + 4, dtype=self.dtype)
        w[:len(row)] = row
        w[S] = s
        w[S + 1:] = scales
        return self.backend.to_device(w)

    @property
    def takes_stable_step(self):
        return not self.adaptive  # its error control sizes the step

    def propose(self, dt):
        if self.adaptive and self.dt_next is not None:
            return min(dt, self.dt_next)
        return dt

    def _attempt(self, state, P):
        S = len(self.b)
        self.map_then_evaluate(state, 0, P, at=0.0)  # the state saved, then k_1 at t
        for s in range(S - 1):  # stage s, then k_(s+2) at its time
            self.map_then_evaluate(state, 1, P, at=sum(self.A[s + 1]), w=self.stage_w[s])
        self.maps[1](state.view(self.stage_w[S - 1]), P)

    def step(self, state, P):
        if self.b_hat is None:
            self._attempt(state, P)
            return float(P.dt)
        if self.err_w is None:
            diff = [b - bh for b, bh in zip(self.b, self.b_hat)]
            self.err_w = self._weights(diff, 0, (1.0 / state.h, 1.0 / state.c0, 1.0 / state.rho0))
        restore, error = self.maps[2], self.maps[3]
        rejected = 0
        while True:
            dt = float(P.dt)
            self._attempt(state, P)
            err = state.reduce(error, state.view(self.err_w), P)[2]
            self.stats = {"rk_error": err, "rk_rejected": rejected}
            if not self.adaptive:
                return dt
            grow = 5.0 if err == 0 else min(5.0, max(0.2, 0.9 * (self.tol / err) ** 0.2))
            if err <= self.tol:
                self.dt_next = dt * grow
                return dt
            rejected += 1
            restore(state.view(), P)
            new = dt * (grow if math.isfinite(err) else 0.2)
            if new < self.settings.get("dtMin", 0.0) or rejected > 30:
                raise IntegrationError(
                    f"RK45 error control: step rejected {rejected} times, dt = {new:.3g} s "
                    f"(error {err:.3g} > tolerance {self.tol:.3g})")
            P = state.params_for(new)


@register
class RK4(RungeKutta):
    """The classic fourth-order Runge-Kutta scheme (Kutta 1901), four evaluations a step."""
    name, spec_name, ref = 'rk4', None, 'Kutta (1901)'
    order, evaluations = 4, 4
    stable_cfl, safe_cfl = 1.0, 0.5
    A = [[], [0.5], [0.0, 0.5], [0.0, 0.0, 1.0]]
    b = [1 / 6, 1 / 3, 1 / 3, 1 / 6]


@register
class RK45(RungeKutta):
    """Dormand & Prince (1980) RK5(4)7M: fifth-order solution, fourth-order embedded error
    estimate, seven evaluations a step (the first-same-as-last property is not used: the
    particles are re-sorted between steps)."""
    name, spec_name, ref = 'rk45', 'RK45', 'Dormand & Prince (1980)'
    params = (Param("rk45_tolerance", 1e-6, "largest scaled local error of an accepted step", check=POS, table="time"),)
    order, evaluations = 5, 7
    safe_cfl = 0.5  # the error control lowers the step as needed
    A = [[],
         [1 / 5],
         [3 / 40, 9 / 40],
         [44 / 45, -56 / 15, 32 / 9],
         [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729],
         [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
         [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]]
    b = [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0.0]
    b_hat = [5179 / 57600, 0.0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40]


@register
class ImplicitMidpoint(Integrator):
    """Implicit midpoint (IMP), as the WCSPH-BI spec writes it after Cercos-Pita et al.
    (2024): with y = (x, v, rho) and f its time derivative,
    y_n+1 = y_n + dt f(y_n+1/2), y_n+1/2 = y_n + dt/2 f(y_n+1/2), solved by a relaxed
    fixed-point iteration on the midpoint derivatives (v~, rho~):
        v^m = v_n + dt/2 v~^m, rho^m = rho_n + dt/2 rho~^m, x^m = x_n + dt/2 v^m;
        evaluate f at (x^m, v^m, rho^m);
        v~^m+1 = (1 - w) f_v + w v~^m   (and rho~ alike).
    The first guess is the previous step's converged midpoint derivative (the derivative at
    t_0 on the first step). The relaxation weight w of the previous iterate is the spec's
    1 - f: ``midpointRelaxCoef_0`` on the first iteration, then ``midpointRelaxCoef``,
    raised to df + (1 - df) w (df = ``midpointRelaxCoefIncrement``) whenever the residual
    fell by less than the factor ``midpointResidualMinimalDecay`` (g_R), i.e. when
    R^m / R^m-1 > g_R (the spec's parenthesis prints the inequality the other way round; its
    words, and TNL-SPH, raise the relaxation when the residual decays too slowly). The
    defaults (0) give the plain iteration, as in TNL-SPH, whose parameter names these are. A relaxed
    iteration converges for steps well beyond the explicit limit: on an acoustic mode of
    frequency w the plain iteration's error is multiplied by dt w / 2 per iteration, the
    relaxed one's by |w + (1 - w) i dt w/2|.

    Convergence is measured by the energy residual, the change of the power terms of the
    energy balance between iterates, R = sum |m v.(a - v~)| + sum |m p/rho^2 (Drho - rho~)|,
    taken relative to their size sum |m v.a| + |m p/rho^2 Drho| so that
    ``midpointResidualTolerance`` does not depend on units or particle count. The iteration
    stops below the tolerance, after ``midpointMaxInterations`` iterations, or when it has
    stalled at round-off (not halved for 2 iterations, below 1000 machine epsilons: in float32
    the relative residual levels off near 1e-5, short of the spec's default 1e-7), and the
    last evaluation's derivatives (unrelaxed) make the step. The model's wall corrections
    (elastic bounce, NBVC-PST) act once, on the step's end state, as for the explicit
    schemes: inside the iteration they would make the fixed-point map discontinuous.
    The midpoint rule is symplectic and time-reversible, so with a conservative,
    dissipation-free model the energy error stays bounded rather than drifting."""
    name, spec_name, ref = 'midpoint', 'MidpointScheme', 'Cercos-Pita et al. (2024), the WCSPH-BI spec'
    iterated = True
    takes_stable_step = False  # its iterations read their residual, and log each step's size
    refreshing = (2,)  # the midpoint state, before each iteration's evaluation

    ROUNDOFF_FLOOR = 1000.0
    ROUNDOFF_STALL = 2
    params = tuple(Param(k, d, doc, kind=kind, check=chk, table="time", spec=True) for k, d, doc, kind, chk in (
        ("midpointMaxInterations", 50, "largest number of iterations per step", "int", POS),
        ("midpointResidualTolerance", 1e-7, "relative energy residual that ends the iteration", "float", POS),
        ("midpointRelaxCoef", 0.0, "relaxation weight of the previous iterate (1 - f)", "float", UNIT_OPEN),
        ("midpointRelaxCoef_0", 0.0, "the same, on the first iteration", "float", UNIT_OPEN),
        ("midpointResidualMinimalDecay", 0.2, "g_R: a residual ratio above it raises the relaxation", "float", POS),
        ("midpointRelaxCoefIncrement", 0.0, "df of the relaxation's raise w -> df + (1 - df) w", "float",
         UNIT_OPEN)))
    factory = staticmethod(make_midpoint)
    fields = _SAVED + (("dv_t", "vector", False), ("drho_t", "scalar", False))
    order = 2
    stable_cfl, safe_cfl = 1.0, 0.5
    reduce_maps = (3,)
    carried = ("primed",)

    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        self.max_iter = int(self.setting("midpointMaxInterations"))
        self.tol = float(self.setting("midpointResidualTolerance"))
        self.relax0 = float(self.setting("midpointRelaxCoef_0"))
        self.relax = float(self.setting("midpointRelaxCoef"))
        self.decay = float(self.setting("midpointResidualMinimalDecay"))
        self.increment = float(self.setting("midpointRelaxCoefIncrement"))
        self.primed = False
        self.floor = self.ROUNDOFF_FLOOR * float(np.finfo(self.dtype).eps)
        self._w = {}
        self.stats = {"midpoint_iterations": 0, "midpoint_residual": 0.0, "midpoint_relax": 0.0}

    def _weight(self, om):
        if om not in self._w:
            self._w[om] = self.backend.to_device(np.array([om], dtype=self.dtype))
        return self._w[om]

    def step(self, state, P):
        begin, guess, _, residual, relax, finish = self.maps
        if not self.primed:
            state.evaluate(P)
            guess(state.view(), P)
            self.primed = True
        begin(state.view(), P)
        om_next = self.relax
        prev = None
        best, since_best = float("inf"), 0
        it, res = 0, float("inf")
        for it in range(1, self.max_iter + 1):
            self.map_then_evaluate(state, 2, P, at=0.5)  # the midpoint state, its derivatives
            r, size = state.reduce(residual, state.view(), P)[:2]
            res = r / size if size > 0 else (0.0 if r == 0 else float("inf"))
            if res < 0.5 * best:
                best, since_best = res, 0
            else:
                since_best += 1
            # converged: below the tolerance, or stalled at round-off (no new low for
            # ROUNDOFF_STALL iterations (a low: half the last) below ROUNDOFF_FLOOR epsilons)
            done = (res < self.tol or it == self.max_iter or not math.isfinite(res)
                    or (since_best >= self.ROUNDOFF_STALL and best < self.floor))
            if done:
                om = 0.0  # the step takes the last evaluation as it is
            else:
                if it == 1:
                    om = self.relax0
                else:
                    if prev > 0 and res / prev > self.decay:
                        om_next = self.increment + (1.0 - self.increment) * om_next
                    om = om_next
            relax(state.view(self._weight(om)), P)
            if done:
                break
            prev = res
        finish(state.view(), P)
        self.stats = {"midpoint_iterations": it, "midpoint_residual": res, "midpoint_relax": om_next}
        return float(P.dt)




def time_schema():
    """The integrators' part of the ``[time]`` schema: ``integrator`` (a name of ours or the
    spec's; empty: the model's default) and every scheme's parameters."""
    schema = {"integrator": ("str", "", one_of("", *INTEGRATORS, *SPEC_SCHEMES))}
    for cls in INTEGRATORS.values():
        for p in cls.params:
            schema[p.key] = (p.kind, p.default, p.check)
    return schema


def spec_parameters():
    """The spec's runtime parameter names of the integrators and where they live in the case."""
    return {p.key: p.dotted for cls in INTEGRATORS.values() for p in cls.params if p.spec}


def integrator_table():
    """Markdown: every registered scheme, its names, the reference it follows and its
    ``[time]`` parameters (``wcsph slots`` prints it after the model's slots)."""
    rows = ["| `time.integrator` | spec name | follows | order | evaluations a step | parameters (default) |",
            "|---|---|---|---|---|---|"]
    for name, cls in INTEGRATORS.items():
        ps = ", ".join(f"`{p.key}` ({p.default!r})" for p in cls.params)
        rows.append(f"| `{name}` | {f'`{cls.spec_name}`' if cls.spec_name else ''} | {cls.ref} | {cls.order} | "
                    f"{cls.evaluations}{' per iteration' if cls.iterated else ''} | {ps} |")
    return "\n".join(rows)
