"""Open boundaries: inflow and outflow through buffer layers (Tafuni, Domínguez, Vacondio &
Crespo 2018; the buffer zones of TNL-SPH's open-boundary examples).

Each ``[[open_boundary]]`` is a box of buffer particles beside the fluid, at least a kernel
support deep along its ``normal`` (an axis direction pointing from the buffer into the fluid).
Buffer particles sit in the fluid set with ``kind`` = 1 + the boundary's index (fluid: 0), so
fluid particles take them as ordinary neighbours; their own state is prescribed, not
integrated:

* inlet: the velocity is the ``velocity`` formula of x, y, z, t; the density comes from the
  ``pressure`` formula when given, else it is extrapolated from the fluid;
* outlet: the density comes from the prescribed ``pressure`` (default 0: p0); the velocity
  is the ``velocity`` formula when given, else extrapolated from the fluid.

"Extrapolated" is the zeroth-order ghost-node value of Tafuni et al.: the Shepard average
sum_j f_j W_mj V_j / sum_j W_mj V_j over fluid particles around the buffer particle's mirror
image in the boundary plane. Buffer particles move with their prescribed velocity (x += dt v
over the step, whatever the forces on them). After each step: an inlet particle that crossed
the plane becomes fluid and a new one is created one buffer depth behind it; a fluid particle
that crossed an outlet plane becomes an outlet buffer particle, and one that left the far side
of the outlet buffer is removed. The counts go to ``run.json`` (``open_boundary``).

Arrays grow and shrink on the host (on the CUDA backend a round trip per step in which
particles are created or removed): the next thing to move to the device.
"""

import numpy as np

from ..io.expressions import evaluate
from ..io.sampling import PointSampler
from ..physics.kernels import SUPPORT, smoothing_length
from ..physics.registry import one_of

#: the ``[[open_boundary]]`` table, in the config schema's form
OPEN_BOUNDARY = {
    "kind": ("str", None, one_of("inlet", "outlet")),
    "min": ("vec", None, None),
    "max": ("vec", None, None),
    "normal": ("vec", None, None),
    "velocity": ("field", None, None),
    "pressure": ("formula", None, None),
}



def check(src, case, fail):
    """Case errors of the ``open_boundary`` tables (``fail(src, key, message)``); returns
    warnings (a buffer shallower than the kernel support)."""
    dp = case["dp"]
    support = SUPPORT * smoothing_length(case)
    warnings = []
    for k, ob in enumerate(case["open_boundary"]):
        key = f"open_boundary[{k}]"
        for name in ("kind", "min", "max", "normal"):
            if ob[name] is None:
                fail(src, f"{key}.{name}", "missing (required)")
        n = np.asarray(ob["normal"], dtype=float)
        if np.count_nonzero(n) != 1 or abs(float(np.abs(n).sum()) - 1) > 1e-12:
            fail(src, f"{key}.normal", f"must be a unit vector along an axis (from the buffer into the fluid), "
                 f"got {ob['normal']}")
        a = int(np.nonzero(n)[0][0])
        if ob["max"][a] - ob["min"][a] < dp * (1 - 1e-9):
            fail(src, f"{key}.max", "the buffer is thinner than dp along its normal")
        if ob["max"][a] - ob["min"][a] < support * (1 - 1e-9):
            warnings.append(f"{key}: the buffer is {ob['max'][a] - ob['min'][a]:g} m deep, less than the kernel "
                            f"support {support:g} m: fluid near it misses neighbours")
        if ob["kind"] == "inlet" and ob["velocity"] is None:
            fail(src, f"{key}.velocity", "an inlet needs its velocity (numbers or formulas of x, y, z, t)")
        for name in ("velocity",):
            for c in ob[name] or []:
                _check_formula(src, f"{key}.{name}", c, fail)
        if ob["pressure"] is not None:
            _check_formula(src, f"{key}.pressure", ob["pressure"], fail)
    return warnings


def _check_formula(src, key, text, fail):
    from ..io.expressions import ExpressionError, check as check_formula

    if isinstance(text, str):
        try:
            check_formula(text, ("x", "y", "z", "t"))
        except ExpressionError as e:
            fail(src, key, f"{text!r}: {e}")


class OpenBoundaries:
    """The buffers of a case and the per-step update (``before`` / ``after`` a step)."""

    def __init__(self, case, dp, support):
        self.specs = case["open_boundary"]
        self.dim, self.dp = case["dim"], dp
        self.support = support
        self.axis, self.sign, self.plane, self.depth = [], [], [], []
        for ob in self.specs:
            n = np.asarray(ob["normal"], dtype=float)
            a = int(np.nonzero(n)[0][0])
            s = float(np.sign(n[a]))
            self.axis.append(a)
            self.sign.append(s)
            self.plane.append(ob["max"][a] if s > 0 else ob["min"][a])
            self.depth.append(ob["max"][a] - ob["min"][a])
        self.created = 0
        self.removed = 0
        self._saved = None
        self._sampler = None

    # ------------------------------------------------------------------ set-up
    def initial_particles(self, lattice):
        """(x, v, p, kind) of the buffer particles at t = 0; p NaN where not prescribed."""
        xs, vs, ps, kinds = [], [], [], []
        for k, ob in enumerate(self.specs):
            x = lattice(ob["min"], ob["max"], self.dp)
            xs.append(x)
            vs.append(self._velocity(k, x, 0.0) if ob["velocity"] is not None else np.zeros_like(x))
            ps.append(self._pressure(k, x, 0.0) if ob["pressure"] is not None
                      else np.full(x.shape[1], 0.0 if ob["kind"] == "outlet" else np.nan))
            kinds.append(np.full(x.shape[1], k + 1, dtype=np.int64))
        return (np.concatenate(xs, axis=1), np.concatenate(vs, axis=1), np.concatenate(ps),
                np.concatenate(kinds))

    def _velocity(self, k, x, t):
        return np.stack([evaluate(str(c), x, t) for c in self.specs[k]["velocity"]])

    def _pressure(self, k, x, t):
        p = self.specs[k]["pressure"]
        return evaluate(str(p if p is not None else 0.0), x, t)

    def depth_along(self, k, x):
        """Signed distance of points from boundary k's plane, positive on the fluid side."""
        return (x[self.axis[k]] - self.plane[k]) * self.sign[k]

    def _across(self, k, x):
        """Points within the buffer's cross-section (its box along the other axes)."""
        ob, ok = self.specs[k], np.ones(x.shape[1], dtype=bool)
        for a in range(self.dim):
            if a != self.axis[k]:
                ok &= (x[a] >= ob["min"][a] - 1e-9 * self.dp) & (x[a] <= ob["max"][a] + 1e-9 * self.dp)
        return ok

    # ------------------------------------------------------------------ per step
    def before(self, state):
        """Remember the buffer particles' state at the start of the step (after the sort)."""
        kind = state.backend.to_host(state.fluid["kind"])
        idx = np.nonzero(kind > 0)[0]
        x, v, rho = (state.backend.to_host(state.fluid[k]) for k in ("x", "v", "rho"))
        self._saved = (idx, x[:, idx].copy(), v[:, idx].copy(), rho[idx].copy())

    def after(self, state, dt):
        """Prescribe the buffers after the step, then convert, create and remove particles."""
        be, f = state.backend, state.fluid
        idx, x0, v0, rho0 = self._saved
        x, v, rho, kind = (np.array(be.to_host(f[k])) for k in ("x", "v", "rho", "kind"))
        t = state.t + dt
        x[:, idx] = x0 + dt * v0  # buffers move with their own velocity
        v[:, idx] = v0
        rho[idx] = rho0
        self._prescribe(state, x, v, rho, kind, t)
        keep = np.ones(f.n, dtype=bool)
        new_x, new_v, new_rho, new_m, new_kind = [], [], [], [], []
        m = None
        for k, ob in enumerate(self.specs):
            s = self.depth_along(k, x)
            mine = kind == k + 1
            if ob["kind"] == "inlet":
                entered = mine & (s >= 0)
                kind[entered] = 0
                nx = x[:, entered].copy()
                nx[self.axis[k]] -= self.sign[k] * self.depth[k]
                new_x.append(nx)
                new_v.append(self._velocity(k, nx, t))
                new_rho.append(rho[entered])
                if entered.any():  # each new buffer particle takes the mass of the one it replaces
                    m = np.asarray(be.to_host(f["m"])) if m is None else m
                    new_m.append(m[entered])
                new_kind.append(np.full(nx.shape[1], k + 1, dtype=np.int64))
            else:
                kind[(kind == 0) & (s < 0) & self._across(k, x)] = k + 1
                gone = (kind == k + 1) & (s < -self.depth[k])
                keep &= ~gone
                self.removed += int(gone.sum())
        new_x = np.concatenate(new_x, axis=1) if new_x else np.zeros((self.dim, 0))
        self.created += new_x.shape[1]
        new = None
        if new_x.shape[1]:
            new = {"x": new_x, "v": np.concatenate(new_v, axis=1), "rho": np.concatenate(new_rho),
                   "m": np.concatenate(new_m), "kind": np.concatenate(new_kind)}
        for name, a in (("x", x), ("v", v), ("rho", rho), ("kind", kind)):
            f[name] = be.to_device(a.astype(f[name].dtype))
        if new is not None or not keep.all():
            resize(state, keep, new)

    def _prescribe(self, state, x, v, rho, kind, t):
        """Inlet velocities (and densities from a prescribed pressure), outlet densities (and
        velocities from a formula); the rest extrapolated from the fluid."""
        eos_rho = state.model.q.eos_density
        P = state.P._replace(**{f: float(val) for f, val in state.P._asdict().items()})
        need_rho, need_v = np.zeros(len(kind), bool), np.zeros(len(kind), bool)
        for k, ob in enumerate(self.specs):
            mine = kind == k + 1
            if not mine.any():
                continue
            xm = x[:, mine]
            if ob["velocity"] is not None:
                v[:, mine] = self._velocity(k, xm, t)
            else:
                need_v |= mine
            if ob["pressure"] is not None or ob["kind"] == "outlet":
                rho[mine] = np.asarray(eos_rho(P.p0 + self._pressure(k, xm, t), P), dtype=float)
            else:
                need_rho |= mine
        need = need_rho | need_v
        if need.any():
            sums = self._extrapolate(state, x, kind, np.nonzero(need)[0])
            w, srho, sv = sums
            ok = w > 1e-6
            sel = np.nonzero(need)[0]
            good = sel[ok]
            if need_rho.any():
                m = need_rho[good]
                rho[good[m]] = srho[ok][m] / w[ok][m]
            if need_v.any():
                m = need_v[good]
                v[:, good[m]] = sv[:, ok][:, m] / w[ok][m]

    def _extrapolate(self, state, x, kind, sel):
        """Shepard sums (sum W V, sum W V rho, sum W V v) over fluid particles around the
        mirror images of particles ``sel`` in their boundary planes."""
        pts = x[:, sel].copy()
        for k in range(len(self.specs)):
            mine = kind[sel] == k + 1
            a = self.axis[k]
            pts[a, mine] = 2 * self.plane[k] - pts[a, mine]
        if self._sampler is None:
            self._sampler = PointSampler(state, skip_buffers=True)
        sums = self._sampler.sums(pts)
        return sums["w"], sums["rho"], sums["v"]

    def summary(self):
        return {"created": self.created, "removed": self.removed}

    def carried_state(self):
        return {"created": self.created, "removed": self.removed}

    def restore(self, state):
        self.created, self.removed = state["created"], state["removed"]


def resize(state, keep, new):
    """Drop the fluid particles not in ``keep`` and append ``new`` (a dict of x, v, rho,
    kind and m for the particles created): every per-particle array of the fluid set, on the
    host. A new particle's mass is ``new["m"]`` where given (an inlet: the mass of the buffer
    particle it replaces, which a fitted box's cell or a classic continuity start made its
    own), else the particle mass; its id the next free one, a saved copy of a
    field (an integrator's ``v_n``, ``rho_n``) its current value, every other field zero."""
    be, f = state.backend, state.fluid
    n_new = 0 if new is None else new["x"].shape[1]
    scratch_or_new = {}
    next_id = None
    for k in f.per_particle():
        a = np.asarray(be.to_host(f[k]))[..., keep]
        if n_new:
            if k in new:
                add = np.asarray(new[k], dtype=a.dtype)
            elif k == "m":
                add = np.full(n_new, state.mass, dtype=a.dtype)
            elif k == "id":
                if next_id is None:
                    next_id = int(np.asarray(be.to_host(f["id"])).max()) + 1
                add = np.arange(next_id, next_id + n_new, dtype=a.dtype)
            elif k.split("_")[0] in new and a.ndim == np.ndim(new[k.split("_")[0]]):
                add = np.asarray(new[k.split("_")[0]], dtype=a.dtype)
            else:
                add = np.zeros(a.shape[:-1] + (n_new,), dtype=a.dtype)
            a = np.concatenate([a, add], axis=-1)
        scratch_or_new[k] = a
    for k, a in scratch_or_new.items():
        f[k] = be.to_device(np.ascontiguousarray(a))
    f.n = int(keep.sum()) + n_new
    for k in [k for k in f.arrays if k.startswith("_")]:
        del f.arrays[k]  # the sort's spare arrays, sized for the old count
