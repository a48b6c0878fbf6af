"""Floating rigid bodies: a wall source (an obstacle box, a polygon, a wall mesh) with a
``floating`` table moves under the fluid's force and torque and gravity, as DualSPHysics'
floatings do.

Mass properties come from the geometry (uniform ``density``) unless given: the mass (per unit
width in 2D), the centre of mass and the moment of inertia about it (2D: a number; 3D: the
tensor). The body's state is its centre of mass c, velocity u, orientation (2D: the angle
theta; 3D: the rotation matrix R, kept orthonormal) and angular velocity omega. Each fluid
step ends with one rigid-body step of the same dt (symplectic Euler, the loads of the fluid
at the step's end):

    u += dt (F / M + g),   c += dt u,
    2D: omega += dt T / I,           theta += dt omega;
    3D: L += dt T (L = R I R^T omega),  omega = (R I R^T)^-1 L,  R = exp(dt [omega]x) R;

and the wall points are placed from the new state (``motion.Bodies.place``), their velocity
u + omega x r and acceleration a + alpha x r + omega x (omega x r) read by the wall terms and
the wall pressure. Explicit coupling, as DualSPHysics' is, is unstable for a body lighter than the fluid that
moves with it (its added mass): each step's load answers the previous step's acceleration
with the opposite sign, amplified by m_added / M (a flat box of 0.3-0.4 times water's density
blew up in tens of steps). The step therefore relaxes the accelerations with an artificial
added mass, (M + M_a) a_new = F + M g + M_a a_old, and I_a likewise: the amplification becomes
(M_a - m_added) / (M + M_a), below 1 when M_a > (m_added - M) / 2, and a constant load is
reached exactly (a lag of about M_a / M steps, milliseconds). ``added_mass`` C_a sets
M_a = C_a rho0 V and I_a = C_a rho0 J (V, J the body's volume and its inertia per unit
density): 1 by default, 0 for the plain explicit step. ``release``: the body is held where it is
until then (DualSPHysics' FtPause), so that the fluid settles around it first.

Constraints, as DualSPHysics' floatings have them: ``translation`` and ``rotation`` say which
degrees of freedom are free (``translation = [true, false]`` keeps a 2D body at its height;
``rotation = [false]`` keeps it from turning; in 3D ``rotation`` has three flags, about x, y
and z): a fixed one keeps its velocity and acceleration at zero, and the free ones are solved
for with the fixed ones' reactions left out (the sub-block of the inertia). ``hinge`` (a point)
makes the body turn about that point instead of its centre of mass (a flap, a gate, a
pendulum): the moment of inertia is taken about the hinge (parallel axes), the torque of the
fluid and of gravity too, and the centre moves on its circle; with ``rotation`` in 3D the
hinge becomes an axis.

Springs and mooring lines (``springs``, a list): each joins a point of the body (``point``,
where it is at the start; default the centre of mass) to a fixed ``anchor`` with a linear
force along the line, k (L - L0) + c dL/dt (``stiffness`` k in N/m, per metre of width in 2D;
``rest_length`` L0, default the starting distance; ``damping`` c in N s/m), pulling the body
towards the anchor when positive; ``line = true`` makes it a slack mooring line that pulls and
never pushes. The force and its torque about the centre join the fluid's and gravity's in the
body's step (explicit: a step well below the spring's period 2 pi sqrt(M/k) is assumed, which
the fluid's step is by far). Each spring's tension is a probes.csv column.

Contact: a body meets the tank's walls (its faces, the open top aside) as rigid, inelastic
contact: after each step, a wall point of the body that has passed a tank face puts the body
back on the face (along its free axes), and impulses along the face's normal through the
contact points (the ends, along the face, of the points past it) remove the velocity into the
face there, turning the body as well (rigid, inelastic). A body resting on the floor stays
there; one thrown at a wall stops at it; one landing on a corner falls flat. The contacts are
frictionless unless ``friction`` gives Coulomb's coefficient mu: then impulses along the face
at the same points also take out the sliding speed there, each at most mu times that point's
normal impulse, so that a body on a slope stays where tan(slope) <= mu and slides with
g (sin - mu cos) where it is steeper (with another body, the lesser of the two mu). The
same holds a body out of the case's fixed obstacle boxes and closed polygons (their
faces as half-spaces, ``wall_contacts``): wall points of the body inside one move the body out
through the face that needs the least motion (along its normal, on the free axes: a body
held to vertical motion leaves upward, never through a side it cannot move along), and
impulses through them take its velocity into the obstacle out, turning it as at the tank's
faces. Every contact is one mechanism, ``collide`` between two sides: a floating body and
another, or a floating body and a wall (``Driven``: the fixed tank faces and obstacles as
one that does not move, ``FloatingBody.fixed``; a wall on a path as one that moves).
Two floating bodies are parted in the frame of the one entered,
which must be convex (a box, a convex polygon, a closed convex wall mesh: its faces as
half-spaces), the push out through its nearest face shared in inverse proportion to their
masses, and impulses through the contact points, equal and opposite on the two, remove their
approach there and turn both (momentum and angular momentum kept). A concave polygon, fixed
or floating (2D), is held as its convex pieces (``convex_pieces``: ear clipping, then pieces
merged while convex), each pushed out of only through the polygon's own edges, not the
diagonals between pieces. A concave closed 3D mesh, floating or a fixed ``[[walls]]`` mesh,
is held as itself (``MeshShape``): a point is inside where a ray from it crosses the mesh an
odd number of times, and the deepest point inside leaves through its nearest point of the
surface, up to
``MESH_PASSES`` pushes per contact (an inner corner takes one per face). An obstacle box or
closed polygon on a prescribed path (``Driven``) is the other side of such a contact with an
infinite mass: the push is all the floating body's, and the impulses take out the speed at
which the body approaches the obstacle's moving surface (a piston pushes a box ahead of it
at its own speed); a closed wall mesh on a path likewise. A container (the tank box on a path; a
convex closed wall mesh with the fluid inside or a convex closed polygon running
counter-clockwise, fixed or moving) holds a body inside
its faces the same way, the impulses taking out the speed at which the body approaches the
moving face. Every other wall (a wall particle file, an open polygon, a concave container
mesh or polygon), fixed or on a path, holds a body out by its wall points: a point inside one of the
body's shapes pushes it out as a point of another body would (``Driven`` with no shapes).
"""
import math

import numpy as np

from ..errors import CaseError
from ..physics.registry import REQUIRED

#: the ``floating`` table of a wall source
FLOATING = {
    "density": ("float", 0.0, None),
    "mass": ("float", 0.0, None),
    "centre": ("vec", None, None),
    "inertia": ("float", 0.0, None),
    "release": ("float", 0.0, None),  # held fixed until this time (the fluid settles around it)
    "added_mass": ("float", 1.0, None),  # the relaxation's added mass, in the fluid's mass the body displaces
    "translation": ("flags", None, None),  # free translation axes (default: all free)
    "rotation": ("rotation_flags", None, None),  # free rotation (2D: one flag; 3D: about x, y, z)
    "hinge": ("vec", None, None),  # the point the body turns about (default: its centre of mass)
    # Coulomb's friction coefficient of its contacts (0: frictionless; with another body the
    # lesser of the two)
    "friction": ("float", 0.0, (lambda v: v >= 0, "must be zero or positive")),
    "springs": ([{  # springs and mooring lines to fixed anchors (see the module)
        "anchor": ("vec", REQUIRED, None),
        "point": ("vec", None, None),  # on the body, where it is at the start (default: the centre of mass)
        "stiffness": ("float", REQUIRED, (lambda v: v > 0, "must be positive")),
        "rest_length": ("float", -1.0, None),  # negative: the starting distance
        "damping": ("float", 0.0, (lambda v: v >= 0, "must be zero or positive")),
        "line": ("bool", False, None),  # a mooring line: pulls, never pushes
    }], [], None),
}


def box_properties(lo, hi):
    """(volume, centroid, inertia per unit density about the centroid) of a box; 2D: area and
    the polar moment, 3D: the tensor."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    e = hi - lo
    vol = float(np.prod(e))
    c = 0.5 * (lo + hi)
    if e.size == 2:
        return vol, c, vol * (e[0] ** 2 + e[1] ** 2) / 12.0
    return vol, c, vol / 12.0 * np.diag([e[1] ** 2 + e[2] ** 2, e[0] ** 2 + e[2] ** 2, e[0] ** 2 + e[1] ** 2])


def holds_fluid(points):
    """Whether a closed polygon ``points`` ((M, 2), in order) holds its fluid inside: its
    points run counter-clockwise (the fluid on the left of the direction of travel, as on
    every polygon wall); a clockwise one is a body, with the fluid outside."""
    pts = np.asarray(points, dtype=float)
    return bool(np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1]) > 0)


def polygon_properties(points, segments=None):
    """(area, centroid, polar moment per unit density about the centroid) of a closed simple
    polygon (either orientation): its ``points`` in order, or the closed outline of
    ``segments`` (index pairs into ``points``, consistently oriented, as a 2D mesh has them)."""
    p = np.asarray(points, dtype=float)
    if segments is None:
        segments = np.stack([np.arange(len(p)), np.roll(np.arange(len(p)), -1)], axis=1)
    (x, y), (xn, yn) = p[segments[:, 0]].T, p[segments[:, 1]].T
    cr = x * yn - xn * y
    a = 0.5 * cr.sum()
    cx = ((x + xn) * cr).sum() / (6 * a)
    cy = ((y + yn) * cr).sum() / (6 * a)
    ixx = ((y * y + y * yn + yn * yn) * cr).sum() / 12.0  # about the origin, signed with a
    iyy = ((x * x + x * xn + xn * xn) * cr).sum() / 12.0
    area = abs(a)
    j = abs(ixx + iyy) - area * (cx * cx + cy * cy)
    return area, np.array([cx, cy]), j


def mesh_properties(verts, faces):
    """(volume, centroid, inertia tensor per unit density about the centroid) of a closed
    triangle mesh: the signed tetrahedra from the origin to each face (either orientation)."""
    v = np.asarray(verts, dtype=float)
    a, b, c = (v[faces[:, k]] for k in range(3))
    vol6 = np.einsum("ij,ij->i", a, np.cross(b, c))
    vol = vol6.sum() / 6.0
    s = a + b + c
    centroid = (vol6[:, None] * s).sum(axis=0) / (24.0 * vol)
    # covariance sum_tet V/20 (a a^T + b b^T + c c^T + s s^T) about the origin
    cov = sum(np.einsum("i,ij,ik->jk", vol6 / 120.0, q, q) for q in (a, b, c, s))
    sign = 1.0 if vol > 0 else -1.0
    vol, cov = abs(vol), sign * cov
    cov_c = cov - vol * np.outer(centroid, centroid)
    return vol, centroid, np.trace(cov_c) * np.eye(3) - cov_c


class FloatingBody:
    """A rigid body's mass properties and state; ``pose`` has the interface of ``motion.Motion``
    (displacement of the centre, rotation, velocities, accelerations)."""

    container = ()  # no faces another body stays inside of (``Driven.container``)

    def __init__(self, key, dim, mass, centre, inertia, release=0.0, added_mass=0.0, added_inertia=0.0,
                 translation=None, rotation=None, hinge=None, springs=(), friction=0.0):
        if not mass > 0 or not np.all(np.isfinite(inertia)) or np.any(np.linalg.eigvalsh(np.atleast_2d(inertia)) <= 0):
            raise CaseError(f"{key}.floating: the body needs a positive mass and inertia (got mass {mass:g})")
        self.key, self.dim, self.mass, self.release = key, dim, float(mass), float(release)
        self.friction = float(friction)
        self.added_mass = float(added_mass)
        if dim == 3:  # a tensor (0: none)
            self.added_inertia = np.asarray(added_inertia, dtype=float) if np.ndim(added_inertia) else np.zeros((3, 3))
        else:
            self.added_inertia = float(added_inertia)
        self.moved = False  # the first step takes the loads as they are (nothing to relax toward)
        self.inertia = np.asarray(inertia, dtype=float) if dim == 3 else float(inertia)
        self.c0 = np.asarray(centre, dtype=float)
        self.c = self.c0.copy()
        self.u = np.zeros(dim)
        self.theta = 0.0
        self.R = np.eye(3) if dim == 3 else None
        self.omega = np.zeros(3) if dim == 3 else 0.0
        self.du = np.zeros(dim)
        self.alpha = np.zeros(3) if dim == 3 else 0.0
        self.hinge = None if hinge is None else np.asarray(hinge, dtype=float)
        free_t = [True] * dim if translation is None else list(translation)
        self.free_t = np.array([False] * dim if self.hinge is not None else free_t, dtype=float)
        free_r = [True] * (1 if dim == 2 else 3) if rotation is None else list(rotation)
        self.free_r = np.array(free_r, dtype=bool)
        self.springs = [Spring(sp, self.c0, dim) for sp in springs]
        self.tensions = [0.0] * len(self.springs)  # at the last step, for probes.csv
        self.points = np.zeros((dim, 0))  # the wall points about c0 (contact), set by ``meet``
        self.reach = 0.0  # the radius about c beyond which nothing is inside it (``meet``)
        self.fixed = None  # the fixed walls it meets, as one ``Driven`` side of its contacts (``meet``)
        self.box = None  # (lo, hi) about c0 in the body's frame, when the body is an obstacle box
        self.hull = None  # (N (m, dim), o (m)): a convex body's faces about c0, inside where N y < o
        self.pieces = []  # a concave body's convex pieces (2D) or mesh (3D) about c0 (``shapes``)

    def meet(self, points, planes, blocks=()):
        """The body's wall points (dim, K) at rest, the faces it must stay inside of
        ((unit normal, offset): inside where n . x >= offset) and the fixed convex obstacles it
        must stay out of (``wall_contacts``, ``box_faces``: (N, o) half-spaces, inside where
        N x < o)."""
        self.points = np.asarray(points, dtype=float) - self.c0[:, None]
        # beyond this distance from its centre no point is inside any of its shapes (which its
        # wall points line, within a spacing)
        self.reach = 2.0 * float(np.max(np.linalg.norm(self.points, axis=0))) if self.points.shape[1] else 0.0
        blocks = [b if isinstance(b, MeshShape) else
                  (np.asarray(b[0], dtype=float), np.asarray(b[1], dtype=float)) + tuple(b[2:]) for b in blocks]
        # the fixed faces and obstacles are the other side of a contact as a wall on a path is
        # (``collide``), one that does not move
        self.fixed = (Driven(Still(self.dim), np.zeros(self.dim), np.zeros((self.dim, 0)), blocks, planes)
                      if len(planes) or len(blocks) else None)

    def wall_points(self):
        """Its wall points where it is now (dim, K)."""
        R = self.R if self.dim == 3 else _rot2(self.theta)
        return self.c[:, None] + R @ self.points

    def pose(self, t):
        """(d, R, u, omega, du, alpha): the centre's displacement from where it started, the
        rotation, the velocity, the angular velocity, the accelerations (t is not used: the
        state is the body's own)."""
        R = self.R if self.dim == 3 else _rot2(self.theta)
        return self.c - self.c0, R, self.u, self.omega, self.du, self.alpha

    def step(self, dt, force, torque, gravity, t=None):
        """One symplectic Euler step under the fluid's ``force`` and ``torque`` (about c) and
        ``gravity``, ending at time ``t``; none before the body's ``release`` time. The
        accelerations are relaxed by the artificial added mass M_a and inertia I_a
        (``added_mass``): (M + M_a) a_new = F + M g + M_a a_old, which a body at rest or in
        free fall does not feel and which keeps a light body stable (see the module). Then
        the constraints and the contact with the tank's faces."""
        if t is not None and t <= self.release:
            return
        F = np.asarray(force, dtype=float) + self.mass * np.asarray(gravity, dtype=float)
        if self.springs:
            sf, st = self._spring_loads()
            F = F + sf
            torque = np.asarray(torque, dtype=float) + st
        first = not self.moved
        self.moved = True
        Ma = 0.0 if first else self.added_mass
        if self.hinge is not None:
            self._turn_about_hinge(dt, F, torque, Ma, first)
        else:
            self.du = self.free_t * (F + Ma * self.du) / (self.mass + Ma)
            self.u = self.u + dt * self.du
            self.c = self.c + dt * self.u
            self._turn(dt, np.asarray(torque, dtype=float), self.inertia, 0.0 if first else self.added_inertia)
        self.settle()
        if self.springs:
            self._spring_loads()  # the tensions at the step's end, as probes.csv reports the state

    def settle(self):
        """The contacts with the fixed walls (the tank's faces, the fixed obstacles) again: after
        its step, after a push by another body (``collide`` with ``fixed``)."""
        if self.fixed is not None:
            collide(self, self.fixed)

    def _spring_loads(self):
        """The springs' force on the body and their torque about its centre, now."""
        R = self.R if self.dim == 3 else _rot2(self.theta)
        F, T = np.zeros(self.dim), np.zeros(3 if self.dim == 3 else 1)
        for k, sp in enumerate(self.springs):
            r = R @ sp.offset
            q = self.c + r
            v = self.u + (np.cross(self.omega, r) if self.dim == 3 else self.omega * np.array([-r[1], r[0]]))
            f, self.tensions[k] = sp.force(q, v)
            F = F + f
            T = T + (np.cross(r, f) if self.dim == 3 else np.array([r[0] * f[1] - r[1] * f[0]]))
        return F, T

    def _turn(self, dt, torque, inertia, added):
        """The rotation's step about the body's centre (2D: ``inertia`` a number; 3D: the
        tensor in the body's frame), the fixed rotation axes held."""
        if self.dim == 2:
            if not self.free_r[0]:
                self.alpha, self.omega = 0.0, 0.0
                return
            self.alpha = (float(np.ravel(torque)[0]) + added * self.alpha) / (inertia + added)
            self.omega = self.omega + dt * self.alpha
            self.theta = self.theta + dt * self.omega
            return
        Iw = self.R @ inertia @ self.R.T
        Ia = self.R @ added @ self.R.T if np.ndim(added) else np.zeros((3, 3))
        T = torque - np.cross(self.omega, Iw @ self.omega)  # Euler's equations
        self.alpha = _solve_free(Iw + Ia, T + Ia @ self.alpha, self.free_r)
        self.omega = self.omega + dt * self.alpha
        self.R = _exp(dt * self.omega) @ self.R
        u, _, vt = np.linalg.svd(self.R)  # re-orthonormalised (round-off only)
        self.R = u @ vt

    def _turn_about_hinge(self, dt, F, torque, Ma, first):
        """The step of a body turning about its hinge p: the inertia about p (parallel axes,
        the added inertia likewise), the torque about p of the fluid and of gravity, the
        centre carried round p; its velocity omega x r and acceleration alpha x r +
        omega x (omega x r)."""
        p, r = self.hinge, self.c - self.hinge
        if self.dim == 2:
            Ip = self.inertia + self.mass * (r @ r)
            Ia = 0.0 if first else self.added_inertia + Ma * (r @ r)
            Tp = float(np.ravel(torque)[0]) + (r[0] * F[1] - r[1] * F[0])
            theta0 = self.theta
            self._turn(dt, Tp, Ip, Ia)
            rot = _rot2(self.theta - theta0)
            r = rot @ r
            self.c = p + r
            k_r = np.array([-r[1], r[0]])
            self.u = self.omega * k_r
            self.du = self.alpha * k_r - self.omega * self.omega * r
            return
        Rt = self.R.T  # the body frame: the inertia about p, carried to the world frame in _turn
        Ip = self.inertia + Rt @ _parallel_axes(self.mass, r) @ self.R
        Ia = np.zeros((3, 3)) if first else self.added_inertia + Rt @ _parallel_axes(Ma, r) @ self.R
        R0 = self.R
        self._turn(dt, np.asarray(torque, dtype=float) + np.cross(r, F), Ip, Ia)
        r = self.R @ R0.T @ r
        self.c = p + r
        wr = np.cross(self.omega, r)
        self.u = wr
        self.du = np.cross(self.alpha, r) + np.cross(self.omega, wr)

    def _responses(self, n, r):
        """(du, dw, arms) of unit impulses along n through the points r (dim, K, about the
        centre): du = n/M on the free translations (the same for every point), dw (K, a number
        in 2D, a vector in 3D) = I^-1 (r x n) on the free rotations, and the arms r x n, with
        which a point's speed along n is u . n + w . (r x n)."""
        if self.dim == 2:
            arms = r[0] * n[1] - r[1] * n[0]
            dw = arms / self.inertia if self.free_r[0] else np.zeros_like(arms)
        else:
            arms = np.cross(r.T, n)
            dw = np.zeros_like(arms)
            f = np.flatnonzero(self.free_r)
            if f.size:
                Iw = self.R @ self.inertia @ self.R.T
                dw[:, f] = np.linalg.solve(Iw[np.ix_(f, f)], arms[:, f].T).T
        return self.free_t * n / self.mass, dw, arms

    def faces(self):
        """The body's convex shape as half-spaces in its own frame about its centre, (N, o):
        outward unit normals (m, dim) and offsets, inside where N y < o; from its box (the
        faces +x, -x, +y, ...) or its convex polygon or mesh (``hull``); None when it has
        neither (a concave body meets others through the fluid alone)."""
        if self.hull is not None:
            return self.hull
        if self.box is None:
            return None
        return box_faces(*self.box)

    def shapes(self):
        """The shapes other bodies stay out of, in its own frame about its centre: its
        ``faces`` as one, or a concave polygon's convex pieces (N, o, exposed:
        ``convex_pieces``), or a concave 3D mesh (``MeshShape``)."""
        f = self.faces()
        return [f] if f is not None else list(self.pieces)

    def columns(self, name):
        """The probes.csv columns of this body's state."""
        axes = "xyz"[: self.dim]
        cols = [f"{name}_{c}" for c in axes] + [f"{name}_v{c}" for c in axes]
        tension = [f"{name}_spring{k}_tension" for k in range(len(self.springs))]
        if self.dim == 2:
            return cols + [f"{name}_theta", f"{name}_omega"] + tension
        return (cols + [f"{name}_omega{c}" for c in "xyz"] + [f"{name}_R{i}{j}" for i in range(3) for j in range(3)]
                + tension)

    def values(self, name):
        v = list(self.c) + list(self.u)
        if self.dim == 2:
            v += [self.theta, self.omega]
        else:
            v += list(self.omega) + list(self.R.ravel())
        v += self.tensions
        return {c: float(x) for c, x in zip(self.columns(name), v)}

    def carried_state(self):
        d = {"c": self.c.tolist(), "u": self.u.tolist(), "du": self.du.tolist(), "moved": self.moved}
        if self.dim == 2:
            d.update(theta=self.theta, omega=self.omega, alpha=self.alpha)
        else:
            d.update(R=self.R.tolist(), omega=self.omega.tolist(), alpha=self.alpha.tolist())
        return d

    def restore(self, d):
        self.c, self.u, self.du = (np.asarray(d[k], dtype=float) for k in ("c", "u", "du"))
        self.moved = bool(d["moved"])
        if self.dim == 2:
            self.theta, self.omega, self.alpha = float(d["theta"]), float(d["omega"]), float(d["alpha"])
        else:
            self.R, self.omega, self.alpha = (np.asarray(d[k], dtype=float) for k in ("R", "omega", "alpha"))
        if self.springs:
            self._spring_loads()  # the tensions of the restored state


class Spring:
    """A linear spring or mooring line from a body point to a fixed anchor (see the module)."""

    def __init__(self, table, centre, dim):
        self.anchor = np.asarray(table["anchor"], dtype=float)
        point = centre if table["point"] is None else np.asarray(table["point"], dtype=float)
        self.offset = point - centre  # in the body's frame (its starting orientation)
        self.k, self.c, self.line = float(table["stiffness"]), float(table["damping"]), bool(table["line"])
        start = float(np.linalg.norm(point - self.anchor))
        self.rest = start if table["rest_length"] < 0 else float(table["rest_length"])

    def force(self, q, v):
        """(force on the body at point q moving at v, tension): T = k (L - L0) + c dL/dt along
        the line towards the anchor; a line's is never negative."""
        d = q - self.anchor
        L = float(np.linalg.norm(d))
        if L == 0.0:
            return np.zeros_like(d), 0.0
        e = d / L
        tension = self.k * (L - self.rest) + self.c * float(v @ e)
        if self.line:
            tension = max(tension, 0.0)
        return -tension * e, tension


def _rot2(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


#: sweeps over a contact's points (sequential impulses), and the speed into a face [m/s, or
#: m/s^2 for the accelerations] below which a point counts as stopped
CONTACT_SWEEPS = 64
CONTACT_TOL = 1e-14
#: the depth, relative to a box's size, below which a body's point on the box's face counts
#: as touching it, not inside (the push that put it there leaves it a rounding error deep)
TOUCH = 1e-12


def _extremes(r, n):
    """The contact points that matter among the points r (dim, K) on a face of normal n: the
    ones at the ends of the patch along the face (2D: the two ends; 3D: the ends along two
    directions in the face and along their diagonals), each once."""
    if r.shape[1] <= 2:
        return r
    if r.shape[0] == 2:
        dirs = [np.array([-n[1], n[0]])]
    else:
        t1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(n, t1)
        dirs = [t1, t2, t1 + t2, t1 - t2]
    keep = set()
    for d in dirs:
        s = d @ r
        keep.update((int(np.argmin(s)), int(np.argmax(s))))
    return r[:, sorted(keep)]


def contact_impulses(sides, friction=0.0):
    """Impulses at K contact points that take the speed of approach out at each: ``sides``
    lists (body, n, r) for each body at the contact, n the normal out of the other body or
    the surface, r (dim, K) the points about the body's centre; point k's impulse J_k acts
    along n on each body (equal and opposite on two, their normals opposite). With A the
    speed at which point k parts (along n, summed over the sides) per unit impulse at point l,
    and s_k the speed now, the impulses solve s + A J >= 0, J >= 0, J_k (s + A J)_k = 0 by
    projected Gauss-Seidel (``_projected_gauss_seidel``); the velocities, then the
    accelerations likewise. A landing on a corner turns the body, one on a face stops it
    (rigid, inelastic; with two bodies momentum and angular momentum kept).

    With ``friction`` mu > 0 each point also takes impulses J_t along the face (one direction
    in 2D, two in 3D) with |J_t| <= mu J_n, which take its sliding speed out within that bound
    (a sticking point stops sliding, a slipping one is slowed by mu J_n): rows along the face
    join the normal ones in A (a normal impulse through a point off the centre turns the body
    and moves the points along the face, and the other way round)."""
    n0 = sides[0][1]
    dirs = [n0] + (_tangents(n0) if friction > 0.0 else [])  # the normal, then along the face
    K = sides[0][2].shape[1]
    nd = len(dirs)
    resp = []  # per side, per direction: (du, dw, arms) of impulses along that side's direction
    for body, n, r in sides:
        sign = 1.0 if n @ n0 > 0.0 else -1.0  # the other body's normal is the first's, negated
        resp.append((sign, [body._responses(sign * d, r) for d in dirs]))
    A = np.zeros((nd * K, nd * K))
    for sign, rs in resp:
        for a, d in enumerate(dirs):
            arms = rs[a][2]
            for b in range(nd):
                du, dw, _ = rs[b]
                A[a * K:(a + 1) * K, b * K:(b + 1) * K] += float(sign * d @ du) + (
                    np.outer(arms, dw) if arms.ndim == 1 else arms @ dw.T)
    for va, wa in (("u", "omega"), ("du", "alpha")):
        speed = np.zeros(nd * K)
        for (body, _, _), (sign, rs) in zip(sides, resp):
            w = getattr(body, wa)
            for a, d in enumerate(dirs):
                arms = rs[a][2]
                speed[a * K:(a + 1) * K] += float(getattr(body, va) @ (sign * d)) + (arms * w if arms.ndim == 1 else arms @ w)
        J = _projected_gauss_seidel(A, speed, K, nd, friction)
        for (body, _, _), (sign, rs) in zip(sides, resp):
            for a in range(nd):
                du, dw, _ = rs[a]
                Ja = J[a * K:(a + 1) * K]
                setattr(body, va, getattr(body, va) + Ja.sum() * du)
                setattr(body, wa, getattr(body, wa) + Ja @ dw)


def _tangents(n):
    """Unit directions along a face of unit normal n (2D: one; 3D: two, orthogonal)."""
    if n.size == 2:
        return [np.array([-n[1], n[0]])]
    t1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1)
    return [t1, np.cross(n, t1)]


def _projected_gauss_seidel(A, s, K, nd=1, mu=0.0):
    """J (nd K: the K normal impulses, then K per direction along the face) with the normal
    rows' complementarity (J_n >= 0, s_n + (A J)_n >= 0, one of them zero) and each point's
    impulse along the face within |J_t| <= mu J_n, otherwise taking its sliding speed to zero:
    sequential impulses, each sweep clamping a point's normal impulse at zero and its
    impulse along the face to its disk of radius mu J_n, swept until no row's impulse changes
    the speeds by more than ``CONTACT_TOL`` over a sweep. Plain lists: K is a few points."""
    R = nd * K
    cols = A.T.tolist()  # cols[i][m]: row m's speed per unit impulse of row i
    s, J = [float(v) for v in s], [0.0] * R
    diag = [cols[i][i] for i in range(R)]
    for _ in range(CONTACT_SWEEPS):
        before = list(J)
        for k in range(K):
            rows = [k] + [a * K + k for a in range(1, nd)]
            for m, i in enumerate(rows):
                if diag[i] <= 0.0:
                    continue  # an impulse there moves nothing
                new = J[i] - s[i] / diag[i]
                if m == 0:
                    new = max(new, 0.0)
                dj = new - J[i]
                if dj != 0.0:
                    J[i] = new
                    col = cols[i]
                    for q in range(R):
                        s[q] += dj * col[q]
            if nd == 1:
                continue
            size = math.sqrt(sum(J[i] * J[i] for i in rows[1:]))
            bound = mu * J[k]
            if size > bound:  # sliding: the impulse along the face at Coulomb's bound
                for i in rows[1:]:
                    dj = J[i] * (bound / size) - J[i]
                    J[i] += dj
                    col = cols[i]
                    for q in range(R):
                        s[q] += dj * col[q]
        if max(abs(J[i] - before[i]) * diag[i] for i in range(R)) <= CONTACT_TOL:
            break
    return np.array(J)


def _parallel_axes(mass, r):
    """What a point mass at r adds to a 3D inertia tensor about the origin."""
    return mass * ((r @ r) * np.eye(3) - np.outer(r, r))


def _solve_free(A, b, free):
    """x with A x = b on the free components and 0 on the others (the fixed ones' reactions
    left out)."""
    x = np.zeros(3)
    if free.any():
        f = np.flatnonzero(free)
        x[f] = np.linalg.solve(A[np.ix_(f, f)], b[f])
    return x


def _exp(w):
    """The rotation exp([w]x) (Rodrigues)."""
    a = float(np.linalg.norm(w))
    if a == 0.0:
        return np.eye(3)
    k = w / a
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K


def body_of(key, table, dim, mesh=None, rho0=1000.0):
    """The ``FloatingBody`` of wall source ``table`` (``key`` names it in errors): its mass
    properties from its box, polygon or closed ``mesh`` ((vertices (dim, V), faces)) at its
    ``density``, or its ``mass`` spread uniformly; a given ``centre`` moves the inertia to it
    (parallel axes), a given 2D ``inertia`` replaces it."""
    fl = table["floating"]
    if table.get("min") is not None:
        vol, c, j = box_properties(table["min"], table["max"])
    elif table.get("points") is not None:
        vol, c, j = polygon_properties(table["points"])
    elif mesh is not None:
        verts, faces = mesh
        vol, c, j = (mesh_properties(verts.T, faces) if dim == 3 else polygon_properties(verts.T, faces))
    else:
        raise CaseError(f"{key}.floating: a floating wall file needs its closed surface (mesh = ...) to give "
                        "its volume, centre and inertia")
    rho = fl["density"] if fl["density"] > 0 else fl["mass"] / vol
    mass, inertia = rho * vol, rho * j
    if fl["centre"] is not None:
        d = np.asarray(fl["centre"], dtype=float) - c
        inertia = inertia + (mass * (d @ d) if dim == 2 else _parallel_axes(mass, d))
        c = c + d
    if fl["inertia"] > 0:
        inertia = fl["inertia"]
    ca = fl["added_mass"] * rho0  # M_a = C_a rho0 V, I_a = C_a rho0 J (J: per unit density, about c)
    j_c = j if fl["centre"] is None else (j + (vol * (d @ d) if dim == 2 else _parallel_axes(vol, d)))
    body = FloatingBody(key, dim, mass, c, inertia, fl["release"], ca * vol, ca * j_c,
                        fl["translation"], fl["rotation"], fl["hinge"], fl["springs"], fl["friction"])
    if table.get("min") is not None:  # a box: other floating bodies stay out of it
        body.box = (np.asarray(table["min"], dtype=float) - c, np.asarray(table["max"], dtype=float) - c)
    elif table.get("points") is not None:  # a polygon likewise (a concave one as its convex pieces)
        _hold_out(body, np.asarray(table["points"], dtype=float).T - c[:, None])
    elif mesh is not None:
        verts, faces = mesh
        if dim == 3:  # its faces when convex, else the mesh itself
            local = np.asarray(verts, dtype=float) - c[:, None]
            body.hull = convex_faces(local, faces)
            if body.hull is None:
                body.pieces = [MeshShape(local, faces)]
        else:  # a 2D mesh: its outline's segments in order
            order = _outline(np.asarray(faces))
            if order is not None:
                _hold_out(body, np.asarray(verts, dtype=float)[:, order] - c[:, None])
    return body


def _hold_out(body, outline):
    """The 2D ``outline`` (about the body's centre) other bodies stay out of: its faces when
    it is convex, else its convex pieces."""
    body.hull = convex_faces(outline)
    if body.hull is None:
        body.pieces = convex_pieces(outline) or []


def _outline(segments):
    """The vertex indices of a closed 2D outline in order, from its segments (index pairs,
    consistently oriented); None when they are not one closed loop."""
    nxt = {int(a): int(b) for a, b in segments}
    if len(nxt) != len(segments) or not nxt:
        return None
    start = int(segments[0][0])
    order, k = [start], nxt[start]
    while k != start:
        if k not in nxt or len(order) > len(nxt):
            return None
        order.append(k)
        k = nxt[k]
    return order if len(order) == len(nxt) else None


def tank_planes(tank, dim):
    """The faces of the case's ``tank`` table a floating body stays inside of, as (unit
    normal, offset) with inside where n . x >= offset (the open top left out)."""
    if tank is None:
        return []
    out = []
    for a in range(dim):
        e = np.eye(dim)[a]
        out.append((e, float(tank["min"][a])))
        if not (a == dim - 1 and tank.get("open_top")):
            out.append((-e, -float(tank["max"][a])))
    return out


def collide(a, b):
    """Two bodies kept apart (two floating bodies, or a floating body and a wall: ``Driven``,
    fixed or on a path), each convex shape of one (a box, a convex polygon or mesh: ``faces``;
    a concave body's pieces or mesh: ``shapes``) holding the other's wall points out of it,
    each container's faces (``Driven.container``) holding the other's points inside: the
    points of one inside the other (in that body's frame) part the two by the least push out
    through one of its faces, along that face's normal on their free axes, shared in inverse
    proportion to their masses (a held axis takes none, a wall all of it: ``_part``); then
    impulses along that normal through the contact points (the extremes, along the face, of
    the points that were inside) take the velocity and acceleration of approach out at each
    of them, equal and opposite on the two bodies, turning both (rigid, inelastic: momentum
    and angular momentum kept; friction as ``contact_impulses``). Returns whether they
    touched."""
    touched = False
    for p, q in ((a, b), (b, a)):
        touched = _keep_inside(p, q) or touched
    for p, q, shape in [(p, q, s) for p, q in ((a, b), (b, a)) for s in q.shapes()]:
        if not p.points.shape[1]:
            continue
        for _ in range(_passes(shape)):
            Rq = q.R if q.dim == 3 else _rot2(q.theta)
            x = p.wall_points()
            if q.reach is not None:  # only the points near q can be inside it (a long wall's few)
                x = x[:, np.sum((x - q.c[:, None]) ** 2, axis=0) <= q.reach * q.reach]
                if not x.shape[1]:
                    break
            y = Rq.T @ (x - q.c[:, None])  # p's points in q's frame
            hit = _hit(shape, y, lambda N: _lengths(p, q, N @ Rq.T))
            if hit is None:
                break
            inside, need, nq = hit
            n = Rq @ nq  # out of q, for p
            if not _part(p, q, n, need, x[:, inside]):
                break  # both held along it
            touched = True
    return touched


def _lengths(p, q, n):
    """How far p and q move, together, per unit of their parting along each unit normal n
    (faces, dim) when pushed apart (``_part``): 1 for free bodies, more along a normal their
    held axes are oblique to, infinite where neither can move along it."""
    inv = sum(np.sum(n * n * body.free_t, axis=1) / body.mass for body in (p, q))
    if all(np.all(body.free_t == 1.0) or not np.isfinite(body.mass) for body in (p, q)):
        return np.where(inv > 0.0, 1.0, np.inf)
    moved = sum(np.linalg.norm(n * body.free_t, axis=1) / body.mass for body in (p, q))
    return np.where(inv > 0.0, moved / np.where(inv > 0.0, inv, 1.0), np.inf)


def _part(p, q, n, need, x):
    """p and q pushed apart along the unit normal n (out of q, for p) on their free axes until
    they have parted by ``need`` along it, in inverse proportion to their masses (a wall, of
    infinite mass, takes none), then the impulses through the contact points among x (dim, K:
    p's points that were inside q, where they were) that take their approach out. Returns
    False (nothing done) when neither can move along n."""
    inv_p, inv_q = (float(n @ (body.free_t * n)) / body.mass for body in (p, q))
    if not inv_p + inv_q > 0.0:
        return False
    r = _extremes(x - p.c[:, None], n)  # the contact points about p's centre, which move with p
    a = need / (inv_p + inv_q)
    p.c = p.c + a / p.mass * p.free_t * n
    q.c = q.c - a / q.mass * q.free_t * n
    points = p.c[:, None] + r  # where they are now
    contact_impulses([(p, n, r), (q, -n, points - q.c[:, None])], min(p.friction, q.friction))
    return True


#: sweeps over the pairs of floating bodies at most, per step: a stack of bodies on the floor
#: passes each push on to the floor through the others, a part per sweep
SWEEPS = 16


def part(moving, driven):
    """The floating bodies ``moving`` parted from each other and from the walls ``driven``
    (``Driven``, placed where they are now): Gauss-Seidel sweeps over the pairs (``collide``)
    until none touches or ``SWEEPS``; a body pushed by another is put back inside the tank's
    faces and out of the fixed obstacles (``settle``) at once."""
    pairs = [(a, b) for i, a in enumerate(moving) for b in moving[i + 1:] + list(driven)]
    for _ in range(SWEEPS if pairs else 0):
        touched = False
        for a, b in pairs:
            if collide(a, b):
                touched = True
                for body in (a, b):  # a push must not take a body through the tank or an obstacle
                    if body not in driven:
                        body.settle()
        if not touched:
            break


def _keep_inside(p, q):
    """Body p's wall points back inside the faces of the container q (``Driven.container``:
    the tank's faces, a convex container's, fixed or on a path): the deepest point past a
    face puts p back on it (``_part``: along p's free axes; q does not move), and impulses
    through the contact points take out the speed at which p approaches the face, which moves
    with q. Returns whether p touched a face."""
    faces = q.container
    if not faces or not p.points.shape[1] or not np.isfinite(p.mass):
        return False
    Rq = q.R if q.dim == 3 else _rot2(q.theta)
    touched = False
    x = p.wall_points()
    for n0, o0 in faces:
        n = Rq @ n0
        o = o0 + float(n @ q.c)  # inside where n . x >= o
        past = (o - n @ x) > 0.0
        c = p.c
        if past.any() and _part(p, q, n, float(np.max(o - n @ x[:, past])), x[:, past]):
            x = x + (p.c - c)[:, None]  # a push moves p without turning it
            touched = True
    return touched


#: pushes out of one concave mesh per contact: each takes the deepest point out through its
#: nearest face (an inner corner needs one per face it was pushed into)
MESH_PASSES = 8


def _passes(shape):
    return MESH_PASSES if isinstance(shape, MeshShape) else 1


def _hit(shape, y, lengths):
    """For points y (dim, P) in the frame of ``shape`` (convex (N, o[, exposed]) or a
    ``MeshShape``): None when none is inside (by more than a rounding error), else (which are,
    the push out, its unit direction). A convex shape is left through the face that needs
    the least push to clear them all, measured as the bodies' motion (the push times
    ``lengths`` of the face normals (faces, dim): ``_lengths``); a mesh through the deepest
    point's nearest face."""
    if isinstance(shape, MeshShape):
        return shape.push(y, TOUCH * shape.size)
    N, o = shape[:2]
    depth = o[:, None] - N @ y  # (faces, points): how far inside each face
    slack = TOUCH * _size(N, o)  # a point left on the face by the last push is not inside
    inside = np.all(depth > slack, axis=0)
    if not inside.any():
        return None
    needs = np.max(depth[:, inside], axis=1)  # the push out through each face
    moves = np.where(_exits(shape), needs * lengths(N), np.inf)
    f = int(np.argmin(moves))  # the first of the least
    if not np.isfinite(moves[f]):
        return None  # held along every way out
    return inside, float(needs[f]), N[f]


def box_faces(lo, hi):
    """(N, o) of the box [lo, hi]: the faces +x, -x, +y, ... (inside where N x < o)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    eye = np.eye(lo.size)
    N = np.array([sign * eye[a] for a in range(lo.size) for sign in (1.0, -1.0)])
    o = np.array([v for a in range(lo.size) for v in (hi[a], -lo[a])])
    return N, o


def _size(N, o):
    """A length of the convex shape (N, o): twice its largest offset (a box's largest side,
    for a box about its centre; a piece of a concave body: of the distance of its faces)."""
    return 2.0 * float(np.max(np.abs(o)))


def _exits(shape):
    """Which faces of a convex shape (N, o[, exposed]) a push may leave it through: its own
    edges (a concave body's piece: not the diagonals to its other pieces), or every face when
    it has none of its own (a piece inside the others: it is left, into its neighbour, which
    the next contact leaves)."""
    if len(shape) < 3 or not np.any(shape[2]):
        return np.ones(len(shape[1]), dtype=bool)
    return np.asarray(shape[2], dtype=bool)


def convex_faces(points, tris=None):
    """(N, o) of the convex body whose boundary has these ``points`` (dim, V) about its centre
    (2D: a closed polygon in order; 3D: triangles ``tris`` (F, 3) of vertex indices), inside
    where N y < o with outward unit normals; coplanar faces merged. None when the body is not
    convex (a vertex outside one of its faces' planes by more than 1e-9 of its size)."""
    v = np.asarray(points, dtype=float)
    dim = v.shape[0]
    size = float(np.max(np.linalg.norm(v, axis=0)))
    if dim == 2:
        a, b = v, np.roll(v, -1, axis=1)
        n = np.array([b[1] - a[1], a[0] - b[0]])  # right-hand normals of the edges
    else:
        t = np.asarray(tris)
        a, b, c = (v[:, t[:, k]] for k in range(3))
        n = np.cross((b - a).T, (c - a).T).T
    length = np.linalg.norm(n, axis=0)
    keep = length > 1e-12 * size * size
    n, a = n[:, keep] / length[keep], a[:, keep]
    off = np.einsum("ij,ij->j", n, a)
    flip = off < 0.0  # outward: the centre (the origin, inside a convex body) behind every face
    n[:, flip], off[flip] = -n[:, flip], -off[flip]
    faces = []
    for k in range(n.shape[1]):
        if not any(np.allclose(n[:, k], m, atol=1e-9) and abs(off[k] - q) <= 1e-9 * size for m, q in faces):
            faces.append((n[:, k], float(off[k])))
    N = np.array([m for m, _ in faces])
    o = np.array([q for _, q in faces])
    if np.any(N @ v - o[:, None] > 1e-9 * size):
        return None
    return N, o


def convex_pieces(points):
    """A closed 2D polygon ``points`` (2, V), in order either way round, as convex pieces: a
    list of (N, o, exposed), each piece's outward unit normals (m, 2) and offsets (inside where
    N y < o, in the points' frame) and which of its faces are the polygon's own edges (the
    others are the diagonals between pieces, which a push must not go through). Ear clipping
    into triangles, then neighbouring pieces merged while their union stays convex (Hertel &
    Mehlhorn 1983): a convex polygon is one piece, an L two. None when the outline crosses
    itself (no ear left to clip)."""
    v = np.asarray(points, dtype=float)
    n = v.shape[1]
    size = float(np.max(np.ptp(v, axis=1)))
    eps = 1e-12 * size * size

    def cross(a, b, c):  # > 0: a -> b -> c turns left
        return (v[0, b] - v[0, a]) * (v[1, c] - v[1, a]) - (v[1, b] - v[1, a]) * (v[0, c] - v[0, a])

    area2 = sum(v[0, k] * v[1, (k + 1) % n] - v[0, (k + 1) % n] * v[1, k] for k in range(n))
    order = list(range(n)) if area2 > 0 else list(range(n))[::-1]  # counter-clockwise
    rank = {k: i for i, k in enumerate(order)}
    loop, pieces = order[:], []
    while len(loop) > 3:
        for k in range(len(loop)):
            a, b, c = loop[k - 1], loop[k], loop[(k + 1) % len(loop)]
            if cross(a, b, c) <= eps:
                continue  # a reflex or straight corner is no ear
            if any(cross(a, b, q) >= -eps and cross(b, c, q) >= -eps and cross(c, a, q) >= -eps
                   for q in loop if q not in (a, b, c)):
                continue  # another corner inside (or on) the triangle
            pieces.append([a, b, c])
            del loop[k]
            break
        else:
            return None
    pieces.append(loop)

    def union(P, Q):  # P and Q joined along an edge they share (a, b in P is b, a in Q), or None
        for i in range(len(P)):
            a, b = P[i], P[(i + 1) % len(P)]
            for j in range(len(Q)):
                if Q[j] == b and Q[(j + 1) % len(Q)] == a:
                    p_rest = P[i + 1:] + P[:i + 1]  # b ... a
                    q_rest = Q[j + 1:] + Q[:j + 1]  # a ... b
                    return p_rest + q_rest[1:-1]
        return None

    merged = True
    while merged:
        merged = False
        for i in range(len(pieces)):
            for j in range(i + 1, len(pieces)):
                u = union(pieces[i], pieces[j])
                if u is not None and all(cross(u[k - 1], u[k], u[(k + 1) % len(u)]) >= -eps for k in range(len(u))):
                    pieces[i] = u
                    del pieces[j]
                    merged = True
                    break
            if merged:
                break
    out = []
    for P in pieces:
        a, b = v[:, P], v[:, P[1:] + P[:1]]
        N = np.array([b[1] - a[1], a[0] - b[0]])  # the right-hand normals of counter-clockwise edges: outward
        length = np.linalg.norm(N, axis=0)
        keep = length > 1e-12 * size
        N = (N[:, keep] / length[keep]).T
        o = np.einsum("ij,ji->i", N, a[:, keep])
        exposed = np.array([(rank[q] - rank[p]) % n == 1 for p, q in zip(P, P[1:] + P[:1])])[keep]
        out.append((N, o, exposed))
    return out


def _closest_on_triangles(p, a, b, c):
    """The closest point of triangle (a, b, c) to point p, for K pairs (each (3, K)): the
    Voronoi regions of the corners, edges and face in Ericson's order (Real-Time Collision
    Detection, 2005, 5.1.5)."""
    ab, ac = b - a, c - a
    ap, bp, cp = p - a, p - b, p - c
    d1, d2 = np.einsum("ik,ik->k", ab, ap), np.einsum("ik,ik->k", ac, ap)
    d3, d4 = np.einsum("ik,ik->k", ab, bp), np.einsum("ik,ik->k", ac, bp)
    d5, d6 = np.einsum("ik,ik->k", ab, cp), np.einsum("ik,ik->k", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        inv = 1.0 / (va + vb + vc)
    one, zero = np.ones_like(d1), np.zeros_like(d1)
    regions = [(d1 <= 0) & (d2 <= 0), (d3 >= 0) & (d4 <= d3), (vc <= 0) & (d1 >= 0) & (d3 <= 0),
               (d6 >= 0) & (d5 <= d6), (vb <= 0) & (d2 >= 0) & (d6 <= 0),
               (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)]
    wb = np.select(regions, [zero, one, t_ab, zero, zero, 1.0 - t_bc], vb * inv)
    wc = np.select(regions, [zero, zero, zero, one, t_ac, t_bc], vc * inv)
    return a + ab * wb + ac * wc


class MeshShape:
    """A closed 3D triangle mesh, concave or not, that other bodies stay out of: a point is
    inside where a ray from it crosses the surface an odd number of times (the ray nearly
    vertical, tilted by irrational amounts so that it meets no edge of an axis-aligned mesh;
    Moeller & Trumbore's test against the triangles whose footprint along the ray covers the
    point's bin, so a check costs the triangles near the point's column, not all of them),
    and it leaves through the nearest point of the surface (Ericson 2005, the closest point
    of each triangle). The convex pieces of a concave 2D outline (``convex_pieces``) do the
    same in 2D; a 3D mesh has no such decomposition that is cheap and exact, and needs none
    here."""

    #: candidate pairs (points x triangles) handled at once: bounds the arrays of a large mesh
    CHUNK = 200_000
    #: the inside test's ray
    RAY = np.array([math.sqrt(2.0) * 1e-3, math.sqrt(3.0) * 1e-3, 1.0]) / math.sqrt(1.0 + 5e-6)
    #: triangles per bin of the ray's footprint grid, on average
    PER_BIN = 4

    def __init__(self, verts, tris):
        v = np.asarray(verts, dtype=float)
        t = np.asarray(tris, dtype=np.int64)
        self.a, self.b, self.c = (v[:, t[:, k]] for k in range(3))  # (3, F) each
        self.lo, self.hi = v.min(axis=1), v.max(axis=1)
        self.size = float(np.max(self.hi - self.lo))
        self.e1, self.e2 = self.b - self.a, self.c - self.a
        self.h = np.cross(self.RAY[:, None], self.e2, axis=0)
        self.det = np.einsum("if,if->f", self.e1, self.h)
        self._bins()

    def _bins(self):
        """The triangles by the bins of an xy grid over the mesh that their footprint along the
        ray covers (their xy bounds widened by the ray's drift over the mesh's height), as
        sorted triangle ids and each bin's first (``_start``)."""
        F = self.a.shape[1]
        n = max(1, int(math.sqrt(F / self.PER_BIN)))
        ext = np.maximum(self.hi[:2] - self.lo[:2], 1e-12 * max(self.size, 1e-300))
        self._n, self._cell = n, ext / n
        drift = (self.hi[2] - self.lo[2]) * float(np.max(np.abs(self.RAY[:2]))) + 1e-9 * self.size
        tri = np.stack([self.a[:2], self.b[:2], self.c[:2]])  # (3 corners, 2, F)
        lo = np.clip(np.floor((tri.min(axis=0) - drift - self.lo[:2, None]) / self._cell[:, None]), 0, n - 1)
        hi = np.clip(np.floor((tri.max(axis=0) + drift - self.lo[:2, None]) / self._cell[:, None]), 0, n - 1)
        lo, hi = lo.astype(np.int64), hi.astype(np.int64)
        bins, ids = [], []
        for f in range(F):
            bx, by = np.meshgrid(np.arange(lo[0, f], hi[0, f] + 1), np.arange(lo[1, f], hi[1, f] + 1))
            bins.append((bx * n + by).ravel())
            ids.append(np.full(bins[-1].size, f))
        bins, ids = np.concatenate(bins), np.concatenate(ids)
        order = np.argsort(bins, kind="stable")
        self._tris = ids[order]
        self._start = np.searchsorted(bins[order], np.arange(n * n + 1))

    def inside(self, y):
        """Which of the points y (3, P) are inside the surface."""
        P = y.shape[1]
        ij = np.clip(np.floor((y[:2] - self.lo[:2, None]) / self._cell[:, None]), 0, self._n - 1).astype(np.int64)
        b = ij[0] * self._n + ij[1]
        first, counts = self._start[b], self._start[b + 1] - self._start[b]
        total = int(counts.sum())
        crossings = np.zeros(P, dtype=np.int64)
        if total == 0:
            return crossings == 1
        pi = np.repeat(np.arange(P), counts)
        ti = self._tris[np.repeat(first, counts) + np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)]
        for k in range(0, total, self.CHUNK):
            p, f = pi[k:k + self.CHUNK], ti[k:k + self.CHUNK]
            s = y[:, p] - self.a[:, f]
            with np.errstate(divide="ignore", invalid="ignore"):
                inv = 1.0 / self.det[f]
                u = np.einsum("ik,ik->k", s, self.h[:, f]) * inv
                q = np.cross(s, self.e1[:, f], axis=0)
                v = (self.RAY @ q) * inv
                t = np.einsum("ik,ik->k", self.e2[:, f], q) * inv
            hit = np.isfinite(inv) & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t > 0.0)
            crossings += np.bincount(p[hit], minlength=P)
        return crossings % 2 == 1

    def _chunks(self, n):
        step = max(1, self.CHUNK // max(self.a.shape[1], 1))
        return [slice(k, min(k + step, n)) for k in range(0, n, step)]

    def nearest(self, y):
        """(the nearest point of the surface (3, P), its distance (P)) for points y (3, P). Only
        the triangles that may hold it are tried: those whose bounding sphere (about the
        centroid) comes within the distance of the nearest centroid."""
        q_out = np.empty_like(y)
        d_out = np.empty(y.shape[1])
        cen = (self.a + self.b + self.c) / 3.0
        rad = np.sqrt(np.max([np.einsum("if,if->f", X - cen, X - cen) for X in (self.a, self.b, self.c)], axis=0))
        for sl in self._chunks(y.shape[1]):
            p = y[:, sl]
            d2 = np.einsum("ip,ip->p", p, p)[:, None] + np.einsum("if,if->f", cen, cen)[None, :] - 2.0 * (p.T @ cen)
            dc = np.sqrt(np.maximum(d2, 0.0))
            reach = dc.min(axis=1) * (1.0 + 1e-9) + 1e-12 * self.size
            pi, fi = np.nonzero(dc - rad[None, :] <= reach[:, None])
            q = _closest_on_triangles(p[:, pi], self.a[:, fi], self.b[:, fi], self.c[:, fi])
            dist2 = np.einsum("ik,ik->k", q - p[:, pi], q - p[:, pi])
            dist2[~np.isfinite(dist2)] = np.inf  # a degenerate triangle
            order = np.lexsort((dist2, pi))
            first = order[np.r_[True, pi[order][1:] != pi[order][:-1]]]  # each point's least
            q_out[:, sl] = q[:, first]
            d_out[sl] = np.sqrt(dist2[first])
        return q_out, d_out

    def push(self, y, slack):
        """For points y (3, P) in the mesh's frame: None when none is inside by more than
        ``slack``, else (which are, the push that takes the deepest out through its nearest
        point of the surface, its unit direction); the others follow in the next sweeps."""
        near = np.all((y >= self.lo[:, None] - slack) & (y <= self.hi[:, None] + slack), axis=0)
        if not near.any():
            return None
        idx = np.flatnonzero(near)
        idx = idx[self.inside(y[:, idx])]
        if not idx.size:
            return None
        q, d = self.nearest(y[:, idx])
        deep = d > slack
        if not deep.any():
            return None
        inside = np.zeros(y.shape[1], dtype=bool)
        inside[idx[deep]] = True
        k = int(np.argmax(d))
        return inside, float(d[k]), (q[:, k] - y[:, idx[k]]) / d[k]


class Still:
    """The motion of a wall that does not move (``Driven`` of a fixed wall)."""

    def __init__(self, dim):
        self.dim = dim

    def pose(self, t):
        zero = np.zeros(3) if self.dim == 3 else 0.0
        return np.zeros(self.dim), np.eye(self.dim), np.zeros(self.dim), zero, np.zeros(self.dim), zero


class Driven:
    """A wall, on a prescribed path or fixed (``Still``), as the other side of a contact with
    a floating body (``collide``): its shapes (that a body stays out of), its ``container``
    faces (that a body stays inside of: (n, o), inside where n . y >= o) and its wall points
    (that stay out of a body's shapes), in its own frame about its centre, placed by its
    motion at the contact's time (``at``); it takes no push and no impulse (an infinite
    mass), and its velocity at the contact points enters the speed of approach, so a
    floating body it meets leaves with its speed along the contact's normal (a piston
    pushes a box ahead of it)."""

    mass = math.inf
    friction = math.inf  # a contact takes the floating body's coefficient
    reach = None  # no cull of the points that enter it: a floating body's few

    def __init__(self, motion, centre, points, shapes, container=()):
        self.motion, self.c0 = motion, np.asarray(centre, dtype=float)
        self.dim = self.c0.size
        self.points = np.asarray(points, dtype=float).reshape(self.dim, -1) - self.c0[:, None]
        self.pieces = list(shapes)
        self.container = [(np.asarray(n, dtype=float), float(o)) for n, o in container]
        self.free_t = np.zeros(self.dim)
        self.at(0.0)

    def at(self, t):
        """The wall where its motion has it at time t."""
        d, R, u, self.omega, du, self.alpha = self.motion.pose(t)
        self.c = self.c0 + np.asarray(d, dtype=float)
        self.u, self.du = np.asarray(u, dtype=float), np.asarray(du, dtype=float)
        R = np.asarray(R, dtype=float)
        if self.dim == 2:
            self.theta = math.atan2(R[1][0], R[0][0])
        else:
            self.R = R
        self._x = self.c[:, None] + R @ self.points
        return self

    def wall_points(self):
        """Its wall points where ``at`` put them (dim, K)."""
        return self._x

    def shapes(self):
        return self.pieces

    def _responses(self, n, r):
        """No speed from an impulse: (0, 0, the arms r x n)."""
        arms = r[0] * n[1] - r[1] * n[0] if self.dim == 2 else np.cross(r.T, n)
        return np.zeros(self.dim), np.zeros_like(arms), arms


def wall_contacts(sources, points, body, motions=None, centres=None, meshes=None):
    """Every wall a floating body meets, each wall source classified once, as
    (``planes``, ``blocks``, ``driven``):
    - ``planes``: the faces of the fixed containers ((n, o), inside where n . x >= o): the
      tank's (``tank_planes``), a convex closed polygon's with the fluid inside
      (counter-clockwise), a convex closed mesh's with ``fluid_side = "inside"``;
    - ``blocks``: the fixed obstacles a body stays out of: obstacle boxes, closed polygons
      with the fluid outside (clockwise) and closed wall meshes with the fluid outside, as
      (N, o) half-spaces (inside where N x < o), a concave polygon as its convex pieces (N, o,
      exposed: ``convex_pieces``), a concave 3D mesh as itself (``MeshShape``);
    - ``driven``: the rest as ``Driven`` sides of a contact, each about the centre its motion
      turns it about (a fixed one: ``Still``, about the origin): a box, closed polygon or
      closed mesh with the fluid outside on a prescribed path (its shapes as ``mesh_shapes``
      has them, and its wall points); a container of those kinds on a path, as its
      ``container`` faces; any other wall (a particle file, an open polygon, a concave
      container), fixed or on a path, as its wall points alone, which a floating body's
      shapes hold out.
    ``sources``: (key, table) of each wall source in the bodies' order (``case.config``'s);
    ``points`` (dim, n) the wall points at rest and ``body`` their sources' indices;
    ``motions`` and ``centres`` of each source (``motion.Bodies``'; default: none);
    ``meshes``: {key ("walls[k]"): (vertices, faces)} of the wall meshes that do not float."""
    meshes = meshes or {}
    dim = points.shape[0]
    planes, blocks, driven = [], [], []
    for b, (key, table) in enumerate(sources):
        if table.get("floating") is not None:
            continue
        motion = motions[b] if motions is not None else None
        c = np.asarray(centres[b], dtype=float) if motion is not None else np.zeros(dim)
        own = points[:, body == b]
        outline = None  # a closed outline about c: vertices (dim, V), faces (None: in order)
        if key in meshes:
            verts, faces = (np.asarray(a) for a in meshes[key])
            outline, inside = (verts.astype(float) - c[:, None], faces), table.get("fluid_side") == "inside"
        elif key.startswith("polygon") and table["closed"]:
            pts = np.asarray(table["points"], dtype=float)
            outline, inside = (pts.T - c[:, None], None), holds_fluid(pts)
        shapes, container = [], []
        if key == "tank":
            if motion is None:
                planes.extend(tank_planes(table, dim))
                continue
            container = [(n, o - float(n @ c)) for n, o in tank_planes(table, dim)]
            own = own[:, :0]
        elif key.startswith("obstacle") and table.get("min") is not None:
            shapes = [box_faces(np.asarray(table["min"]) - c, np.asarray(table["max"]) - c)]
        elif outline is not None and inside:
            hull = _hull(*outline)
            if hull is not None:  # a convex container: its faces (a concave one: its points)
                container = [(-N, -o) for N, o in zip(*hull)]
                own = own[:, :0]
        elif outline is not None:
            shapes = polygon_shapes(outline[0]) if outline[1] is None else mesh_shapes(*outline)
        if motion is None and (shapes or container):  # fixed: in the world's frame, as the tank's faces
            blocks.extend(shapes)
            planes.extend(container)
        elif shapes or container or own.shape[1]:
            driven.append(Driven(motion if motion is not None else Still(dim), c, own, shapes, container))
    return planes, blocks, driven


def _hull(verts, faces=None):
    """(N, o) of a closed wall outline or mesh (``verts`` (dim, V); ``faces``: 2D segments, or
    None for vertices in order around; 3D triangles) when it is convex, in its vertices'
    coordinates (inside where N x < o); None when it is not (or a 2D one is not one closed
    loop)."""
    if verts.shape[0] == 2 and faces is not None:
        order = _outline(np.asarray(faces))
        if order is None:
            return None
        verts, faces = verts[:, order], None
    centre = verts.mean(axis=1)
    hull = convex_faces(verts - centre[:, None], faces)
    return None if hull is None else (hull[0], hull[1] + hull[0] @ centre)


def polygon_shapes(pts):
    """The shapes a floating body stays out of for a closed polygon ``pts`` (2, V, in order),
    in its points' coordinates: a convex one as its faces ((N, o), inside where N x < o), a
    concave one as its convex pieces, pushed out through its own edges only."""
    hull = _hull(pts)
    return [hull] if hull is not None else (convex_pieces(pts) or [])


def mesh_shapes(verts, faces):
    """The shapes a floating body stays out of for a closed wall mesh, in its vertices'
    coordinates: a 2D outline as ``polygon_shapes`` (none when it is not one closed loop), a
    convex 3D one as its faces, a concave one as itself (``MeshShape``)."""
    v = np.asarray(verts, dtype=float)
    if v.shape[0] == 2:
        order = _outline(np.asarray(faces))
        return [] if order is None else polygon_shapes(v[:, order])
    hull = _hull(v, faces)
    return [hull] if hull is not None else [MeshShape(v, faces)]
