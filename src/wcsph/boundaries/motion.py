"""Prescribed motion of walls: each tank, obstacle, polygon (and wall file) is a rigid body,
fixed unless it has a ``motion`` table.

A body's wall points move as X(t) = c + d(t) + R(theta(t)) (X0 - c) and their normals as
n(t) = R(theta(t)) n0, with c the body's ``centre`` (its initial centroid when not given),
d(t) the displacement and theta(t) the rotation angle (about z in 2D, about ``axis`` in 3D).
The wall velocity v_b = d'(t) + omega x (X - c - d) is what every wall term reads (the
boundary-integral divergence and viscous terms, Akinci's viscous term, the elastic bounce,
NBVC-PST), as in DualSPHysics' moving boundaries and TNL-SPH's movingSquare2D. The wall
acceleration a_b = d''(t) + omega' x r + omega x (omega x r) (r = X - c - d) is what the wall
pressure reads (Adami, Hu & Adams 2012, eq. 27: p_b carried from the fluid along g - a_b).

Kinds (``motion.kind``):

* ``velocity``: d = U t, theta = omega t (constant ``velocity`` U and ``omega``);
* ``sinusoidal``: d = A r(t) sin(2 pi f t + phi), theta = Theta r(t) sin(2 pi f t + phi)
  (``amplitude`` A, ``angle_amplitude`` Theta, ``frequency`` f, ``phase`` phi); r(t) = 1 unless
  a ``ramp`` of t_r > 0 seconds is given (the wavemakers' ramp below: the body then starts from
  rest without a jerk, where r = 1 starts it at the speed 2 pi f A cos phi at once);
* ``piston`` and ``flap``: a wavemaker for regular waves of ``height`` H and ``period`` T in
  water of ``depth`` h (linear theory). The wave number k solves omega^2 = g k tanh(k h), and
  Biesel's transfer function gives the stroke S (at the still water level) from H: piston
  H/S = 2 (cosh 2kh - 1) / (sinh 2kh + 2kh), moving along x, d = S/2 r(t) sin(omega t + phi);
  flap (hinged at its ``centre``, on the bottom) H/S = 4 sinh(kh)/(kh) (kh sinh kh - cosh kh
  + 1) / (sinh 2kh + 2kh), turning by theta = atan(S / 2h) r(t) sin(omega t + phi). The ramp
  r(t) = (1 - cos(pi t / t_r)) / 2 over ``ramp`` t_r seconds (default two periods) starts it
  without a jerk;
* ``table``: a CSV ``file`` with columns t, x, y[, z], theta (a header row allowed): d and
  theta interpolated linearly, their rates the slopes of the segment t lies in (the exact
  derivative of the interpolated motion); held at the last row after the table ends. The
  acceleration of a table is that of its rates taken at the segments' midpoints and
  interpolated linearly between them (the central difference of the rows: the slopes
  themselves jump at every row).
"""
import collections
import math
from pathlib import Path

import numpy as np
from numba.extending import register_jitable

from ..errors import CaseError
from ..physics.registry import NONNEG, one_of

#: the ``motion`` table of a wall source, in the config schema's form
MOTION = {
    "kind": ("str", "velocity", one_of("velocity", "sinusoidal", "table", "piston", "flap")),
    "velocity": ("vec", None, None),
    "omega": ("float", 0.0, None),
    "amplitude": ("vec", None, None),
    "angle_amplitude": ("float", 0.0, None),
    "frequency": ("float", 0.0, NONNEG),
    "phase": ("float", 0.0, None),
    "centre": ("vec", None, None),
    "axis": ("vec", None, None),
    "file": ("str", "", None),
    "height": ("float", 0.0, NONNEG),
    "period": ("float", 0.0, NONNEG),
    "depth": ("float", 0.0, NONNEG),
    "ramp": ("float", -1.0, None),
}


def wave_number(omega, depth, g):
    """k of linear waves of angular frequency omega in water of the given depth:
    omega^2 = g k tanh(k h), by Newton's method from the deep-water k."""
    k = max(omega * omega / g, omega / math.sqrt(g * depth))
    for _ in range(100):
        t = math.tanh(k * depth)
        f = g * k * t - omega * omega
        k_new = k - f / (g * t + g * k * depth * (1 - t * t))
        if abs(k_new - k) < 1e-14 * k:
            return k_new
        k = k_new
    return k


def wavemaker_stroke(kind, height, period, depth, g):
    """(stroke S at the still water level, k) of a piston or flap wavemaker for waves of
    ``height`` and ``period`` (Biesel's transfer function)."""
    k = wave_number(2 * math.pi / period, depth, g)
    kh = k * depth
    if kind == "piston":
        ratio = 2 * (math.cosh(2 * kh) - 1) / (math.sinh(2 * kh) + 2 * kh)
    else:
        ratio = 4 * math.sinh(kh) / kh * (kh * math.sinh(kh) - math.cosh(kh) + 1) / (math.sinh(2 * kh) + 2 * kh)
    return height / ratio, k


def ramped_sine(t, w, phase, t_ramp):
    """(q, q', q'') of q = r(t) sin(w t + phase), r = (1 - cos(pi t / t_ramp)) / 2 until
    t_ramp, then 1 (r = 1 throughout for t_ramp <= 0)."""
    if t_ramp > 0 and t < t_ramp:
        a = math.pi / t_ramp
        r, r1, r2 = 0.5 * (1 - math.cos(a * t)), 0.5 * a * math.sin(a * t), 0.5 * a * a * math.cos(a * t)
    else:
        r, r1, r2 = 1.0, 0.0, 0.0
    arg = w * t + phase
    sn, cs = math.sin(arg), math.cos(arg)
    return r * sn, r1 * sn + r * w * cs, r2 * sn + 2 * r1 * w * cs - r * w * w * sn


class Motion:
    """d(t), theta(t) and their rates for one ``motion`` table (validated)."""

    def __init__(self, spec, dim, source_dir=".", key="motion", gravity=9.81):
        self.spec, self.dim = spec, dim
        self.kind = spec["kind"]
        if self.kind in ("piston", "flap"):
            if not gravity > 0:
                raise CaseError(f"{key}.kind: a wavemaker needs gravity (linear wave theory)")
            for name in ("height", "period", "depth"):
                if not spec[name] > 0:
                    raise CaseError(f"{key}.{name}: a {self.kind} wavemaker needs the waves' height, period and "
                                    "the water depth at the paddle (> 0)")
            self.stroke, self.k = wavemaker_stroke(self.kind, spec["height"], spec["period"], spec["depth"], gravity)
            self.omega_w = 2 * math.pi / spec["period"]
            self.t_ramp = spec["ramp"] if spec["ramp"] >= 0 else 2 * spec["period"]
        zero = [0.0] * dim
        self.u = np.asarray(spec["velocity"] or zero, dtype=float)
        self.a = np.asarray(spec["amplitude"] or zero, dtype=float)
        axis = np.asarray(spec["axis"] or ([0.0, 0.0, 1.0] if dim == 3 else [0.0]), dtype=float)
        if dim == 3:
            norm = float(np.linalg.norm(axis))
            if norm == 0:
                raise CaseError(f"{key}.axis: must not be zero")
            axis = axis / norm
        self.axis = axis
        if self.kind == "sinusoidal" and spec["frequency"] <= 0:
            raise CaseError(f"{key}.frequency: a sinusoidal motion needs a frequency > 0")
        if self.kind == "sinusoidal":
            self.t_ramp = max(spec["ramp"], 0.0)  # none unless given
        if self.kind == "table":
            if not spec["file"]:
                raise CaseError(f"{key}.file: a table motion needs a CSV file of t, x, y[, z], theta")
            path = Path(source_dir) / spec["file"]
            try:
                data = np.loadtxt(path, delimiter=",", comments="#", ndmin=2,
                                  skiprows=1 if _has_header(path) else 0)
            except (OSError, ValueError) as e:
                raise CaseError(f"{key}.file: cannot read {path}: {e}") from None
            if data.shape[1] != dim + 2 or data.shape[0] < 2:
                raise CaseError(f"{key}.file: {path}: expected at least two rows of {dim + 2} columns "
                                f"(t, {'x, y, z' if dim == 3 else 'x, y'}, theta), got {data.shape}")
            t = data[:, 0]
            if np.any(np.diff(t) <= 0):
                raise CaseError(f"{key}.file: {path}: the times must increase")
            self.table = data
            self.rates = np.diff(data[:, 1:], axis=0) / np.diff(t)[:, None]
            mid = 0.5 * (t[1:] + t[:-1])
            # the rates' slopes between segment midpoints (zero before the first, after the last)
            self.mid = mid
            self.accels = (np.diff(self.rates, axis=0) / np.diff(mid)[:, None]
                           if len(mid) > 1 else np.zeros((0, dim + 1)))

    def _wave(self, t):
        """(q, q', q'') of the wavemaker's coordinate: the piston's displacement, the flap's
        angle."""
        amp = 0.5 * self.stroke if self.kind == "piston" else math.atan(0.5 * self.stroke / self.spec["depth"])
        return tuple(amp * q for q in ramped_sine(t, self.omega_w, self.spec["phase"], self.t_ramp))

    def state(self, t):
        """(d (dim,), theta, d' (dim,), omega) at time t."""
        s = self.spec
        if self.kind in ("piston", "flap"):
            q, q1, _ = self._wave(t)
            zero = np.zeros(self.dim)
            if self.kind == "flap":
                return zero, q, zero, q1
            e = np.eye(self.dim)[0]
            return q * e, 0.0, q1 * e, 0.0
        if self.kind == "velocity":
            return self.u * t, s["omega"] * t, self.u, s["omega"]
        if self.kind == "sinusoidal":
            q, q1, _ = ramped_sine(t, 2 * math.pi * s["frequency"], s["phase"], self.t_ramp)
            return self.a * q, s["angle_amplitude"] * q, self.a * q1, s["angle_amplitude"] * q1
        tab, t0 = self.table, self.table[:, 0]
        row = np.array([np.interp(t, t0, tab[:, k]) for k in range(1, tab.shape[1])])
        if t < t0[0] or t > t0[-1]:
            rate = np.zeros(tab.shape[1] - 1)
        else:
            rate = self.rates[min(max(int(np.searchsorted(t0, t, side="right")) - 1, 0), len(self.rates) - 1)]
        return row[: self.dim], float(row[-1]), rate[: self.dim], float(rate[-1])

    def acceleration(self, t):
        """(d'' (dim,), omega') at time t."""
        s = self.spec
        if self.kind in ("piston", "flap"):
            q2 = self._wave(t)[2]
            if self.kind == "flap":
                return np.zeros(self.dim), q2
            return q2 * np.eye(self.dim)[0], 0.0
        if self.kind == "velocity":
            return np.zeros(self.dim), 0.0
        if self.kind == "sinusoidal":
            q2 = ramped_sine(t, 2 * math.pi * s["frequency"], s["phase"], self.t_ramp)[2]
            return self.a * q2, s["angle_amplitude"] * q2
        mid = self.mid
        if len(self.accels) == 0 or t < mid[0] or t >= mid[-1]:
            return np.zeros(self.dim), 0.0
        acc = self.accels[int(np.searchsorted(mid, t, side="right")) - 1]
        return acc[: self.dim], float(acc[-1])

    def pose(self, t):
        """(d, R, u, omega, du, alpha) at time t: displacement, rotation matrix, velocity,
        angular velocity and the accelerations (omega and alpha: numbers in 2D, vectors along
        ``axis`` in 3D), the interface a floating body (``floating``) shares."""
        d, theta, u, omega = self.state(t)
        du, alpha = self.acceleration(t)
        if self.dim == 3:
            omega, alpha = self.axis * omega, self.axis * alpha
        return d, self.rotation(theta), u, omega, du, alpha

    def rotation(self, theta):
        """The rotation matrix R(theta) (dim x dim)."""
        c, s = math.cos(theta), math.sin(theta)
        if self.dim == 2:
            return np.array([[c, -s], [s, c]])
        k = self.axis
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        return np.eye(3) + s * K + (1 - c) * K @ K


def _has_header(path):
    with open(path, encoding="utf-8") as f:
        first = f.readline()
    try:
        [float(v) for v in first.split(",")]
        return False
    except ValueError:
        return True


class Bodies:
    """The walls' rigid bodies: their names, motions (prescribed, or a floating body's own
    state) and centres, and the placement of the wall points of the moving ones at time t (on
    the host; walls are few beside the fluid)."""

    def __init__(self, specs, dim, x0, n0, body, source_dir=".", floating=None, gravity=9.81):
        """``specs``: one (name, motion table or None, key) per body; ``x0``, ``n0``: the
        wall points and normals (n0 None for wall particles) at t = 0; ``body``: each
        point's body index; ``floating``: {body index: ``floating.FloatingBody``}."""
        self.dim = dim
        self.names = [s[0] for s in specs]
        self.floating = dict(floating or {})
        self.motions = [self.floating[b] if b in self.floating else Motion(m, dim, source_dir, key, gravity)
                        if m is not None else None for b, (_, m, key) in enumerate(specs)]
        self.centres = []
        for b, (_, m, _) in enumerate(specs):
            pts = x0[:, body == b]
            if b in self.floating:
                self.centres.append(self.floating[b].c0)
            elif m is not None and m["centre"] is not None:
                self.centres.append(np.asarray(m["centre"], dtype=float))
            else:
                self.centres.append(pts.mean(axis=1) if pts.shape[1] else np.zeros(dim))
        self.moving = any(m is not None for m in self.motions)
        #: the obstacles on a prescribed path a floating body meets (``floating.Driven``; set up
        #: with the floating bodies' contacts)
        self.driven = []
        # what ``bounds`` needs: each body's box at rest (middle, half-widths), and the box of
        # the points of the bodies that do not move
        self.boxes = [((p.min(axis=1) + p.max(axis=1)) / 2, (p.max(axis=1) - p.min(axis=1)) / 2) if p.shape[1]
                      else (np.zeros(dim), np.zeros(dim)) for p in (x0[:, body == b] for b in range(len(specs)))]
        still = np.isin(body, [b for b, m in enumerate(self.motions) if m is None])
        self.still_box = (x0[:, still].min(axis=1), x0[:, still].max(axis=1)) if still.any() else None
        #: a wall moves along a prescribed path: its place depends on the time alone, so an
        #: evaluation inside a step can see it where it is at that evaluation's time
        self.prescribed = any(m is not None and b not in self.floating for b, m in enumerate(self.motions))

    def poses(self, t):
        """Each body's pose at time t, one row each as ``place_point`` reads it (``POSE``)."""
        rows = np.zeros((len(self.motions), POSE))
        dim = self.dim
        for b, mo in enumerate(self.motions):
            if mo is None:
                continue
            d, R, u, omega, du, alpha = mo.pose(t)
            rows[b, 0] = 1.0
            rows[b, 1:1 + dim] = self.centres[b]
            rows[b, 4:4 + dim] = d
            R3 = np.zeros((3, 3))
            R3[:dim, :dim] = R
            rows[b, 7:16] = R3.ravel()
            rows[b, 16:16 + dim] = u
            rows[b, 22:22 + dim] = du
            if dim == 2:  # about z
                rows[b, 21], rows[b, 27] = omega, alpha
            else:
                rows[b, 19:22], rows[b, 25:28] = omega, alpha
        return rows

    def bounds(self, poses):
        """(lo, hi): a box that holds every wall point where ``poses`` (``poses(t)``) puts it,
        without placing them: each moving body's box at rest, moved and turned as its pose
        says (a box turned by R about its middle m fits in the box of half-widths |R| e about
        c + d + R (m - c)); the other points where they were made."""
        los, his = [], []
        if self.still_box is not None:
            los.append(self.still_box[0])
            his.append(self.still_box[1])
        dim = self.dim
        for b, q in enumerate(poses):
            if q[0] != 0.0:
                mid, half = self.boxes[b]
                R = q[7:16].reshape(3, 3)[:dim, :dim]
                c = q[1:1 + dim]
                m = c + q[4:4 + dim] + R @ (mid - c)
                e = np.abs(R) @ half
                los.append(m - e)
                his.append(m + e)
        if not los:
            return np.zeros(dim), np.zeros(dim)
        return np.min(los, axis=0), np.max(his, axis=0)

    def place(self, t, x0, n0, body):
        """(x, n, v, a) of every wall point at time t on the host: ``make_place`` over the
        points, as Python (the run's backend runs the same function as its map)."""
        x, v, a = np.empty_like(x0), np.empty_like(x0), np.empty_like(x0)
        n = np.empty_like(n0) if n0 is not None else None
        W = WallPlacement(x0, x0 if n0 is None else n0, body, self.poses(t), x, x if n is None else n, v, a)
        place = make_place(self.dim, n0 is not None)
        for i in range(x0.shape[1]):
            place(i, W, None)
        return x, n, v, a

    def reference(self, b, t):
        """The centre of body b at time t (the point torques are taken about)."""
        mo = self.motions[b]
        if mo is None:
            return self.centres[b]
        return self.centres[b] + mo.pose(t)[0]

    def carried_state(self):
        """The floating bodies' states (for checkpoints)."""
        return {str(b): f.carried_state() for b, f in self.floating.items()}

    def restore(self, state):
        for b, f in self.floating.items():
            f.restore(state[str(b)])


#: columns of a body's pose row (``Bodies.poses``): moving (1) or not (0), the centre c (3),
#: the displacement d (3), the rotation R (3 x 3, by rows), the velocity u (3), the angular
#: velocity omega (3), the acceleration du (3), the angular acceleration alpha (3); in 2D the
#: vectors' third component is zero and omega and alpha are about z
POSE = 28

#: a wall set's view for ``make_place``: its points' reference positions and normals, their
#: bodies, the bodies' poses, and what the placement writes
WallPlacement = collections.namedtuple("WallPlacement", "x0 n0 body pose x n v a")


def make_place(dim, normals):
    """place(i, W, P): wall point i of the view W (``WallPlacement``) where its body's pose
    row puts it: x = c + d + R (x0 - c), n = R n0 (``normals``), v = u + omega x r,
    a = du + alpha x r + omega x (omega x r) with r = R (x0 - c); a point of a body that does
    not move stays at x0 at rest. A map of the backend's (jitable), P unused."""

    @register_jitable
    def place(i, W, P):
        b = W.body[i]
        q = W.pose
        if q[b, 0] == 0.0:
            for k in range(dim):
                W.x[k, i] = W.x0[k, i]
                W.v[k, i] = 0.0
                W.a[k, i] = 0.0
                if normals:
                    W.n[k, i] = W.n0[k, i]
            return
        r0 = 0.0
        r1 = 0.0
        r2 = 0.0
        for l in range(dim):
            y = W.x0[l, i] - q[b, 1 + l]
            r0 += q[b, 7 + l] * y
            r1 += q[b, 10 + l] * y
            r2 += q[b, 13 + l] * y
        if dim == 2:
            om, al = q[b, 21], q[b, 27]
            v0, v1, v2 = q[b, 16] - om * r1, q[b, 17] + om * r0, 0.0
            a0 = q[b, 22] + al * -r1 - om * om * r0
            a1 = q[b, 23] + al * r0 - om * om * r1
            a2 = 0.0
        else:
            w0, w1, w2 = q[b, 19], q[b, 20], q[b, 21]
            wr0, wr1, wr2 = w1 * r2 - w2 * r1, w2 * r0 - w0 * r2, w0 * r1 - w1 * r0
            v0, v1, v2 = q[b, 16] + wr0, q[b, 17] + wr1, q[b, 18] + wr2
            g0, g1, g2 = q[b, 25], q[b, 26], q[b, 27]
            a0 = q[b, 22] + (g1 * r2 - g2 * r1) + (w1 * wr2 - w2 * wr1)
            a1 = q[b, 23] + (g2 * r0 - g0 * r2) + (w2 * wr0 - w0 * wr2)
            a2 = q[b, 24] + (g0 * r1 - g1 * r0) + (w0 * wr1 - w1 * wr0)
        W.x[0, i] = q[b, 1] + q[b, 4] + r0
        W.x[1, i] = q[b, 2] + q[b, 5] + r1
        W.v[0, i] = v0
        W.v[1, i] = v1
        W.a[0, i] = a0
        W.a[1, i] = a1
        if dim == 3:
            W.x[2, i] = q[b, 3] + q[b, 6] + r2
            W.v[2, i] = v2
            W.a[2, i] = a2
        if normals:
            for k in range(dim):
                s = 0.0
                for l in range(dim):
                    s += q[b, 7 + 3 * k + l] * W.n0[l, i]
                W.n[k, i] = s

    return place
