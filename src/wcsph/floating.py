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
"""
import math

import numpy as np

from .errors import CaseError

#: the ``floating`` table of a wall source
FLOATING = {
    "density": ("float", 0.0, None),
    "mass": ("float", 0.0, None),
    "centre": ("vec", None, None),
    "inertia": ("float", 0.0, None),
    "release": ("float", 0.0, None),  # held fixed until this time (the fluid settles around it)
    "added_mass": ("float", 1.0, None),  # the relaxation's added mass, in the fluid's mass the body displaces
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

    def __init__(self, key, dim, mass, centre, inertia, release=0.0, added_mass=0.0, added_inertia=0.0):
        if not mass > 0 or not np.all(np.isfinite(inertia)) or np.any(np.linalg.eigvalsh(np.atleast_2d(inertia)) <= 0):
            raise CaseError(f"{key}.floating: the body needs a positive mass and inertia (got mass {mass:g})")
        self.key, self.dim, self.mass, self.release = key, dim, float(mass), float(release)
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
        free fall does not feel and which keeps a light body stable (see the module)."""
        if t is not None and t <= self.release:
            return
        F = np.asarray(force, dtype=float) + self.mass * np.asarray(gravity, dtype=float)
        first = not self.moved
        self.moved = True
        Ma = 0.0 if first else self.added_mass
        self.du = (F + Ma * self.du) / (self.mass + Ma)
        self.u = self.u + dt * self.du
        self.c = self.c + dt * self.u
        if self.dim == 2:
            Ia = 0.0 if first else self.added_inertia
            self.alpha = (float(np.ravel(torque)[0]) + Ia * self.alpha) / (self.inertia + Ia)
            self.omega = self.omega + dt * self.alpha
            self.theta = self.theta + dt * self.omega
            return
        Iw = self.R @ self.inertia @ self.R.T
        Ia = np.zeros((3, 3)) if first else self.R @ self.added_inertia @ self.R.T
        T = np.asarray(torque, dtype=float) - np.cross(self.omega, Iw @ self.omega)  # Euler's equations
        self.alpha = np.linalg.solve(Iw + Ia, T + Ia @ self.alpha)
        self.omega = self.omega + dt * self.alpha
        self.R = _exp(dt * self.omega) @ self.R
        u, _, vt = np.linalg.svd(self.R)  # re-orthonormalised (round-off only)
        self.R = u @ vt

    def columns(self, name):
        """The probes.csv columns of this body's state."""
        axes = "xyz"[: self.dim]
        cols = [f"{name}_{c}" for c in axes] + [f"{name}_v{c}" for c in axes]
        if self.dim == 2:
            return cols + [f"{name}_theta", f"{name}_omega"]
        return cols + [f"{name}_omega{c}" for c in "xyz"] + [f"{name}_R{i}{j}" for i in range(3) for j in range(3)]

    def values(self, name):
        v = list(self.c) + list(self.u)
        if self.dim == 2:
            v += [self.theta, self.omega]
        else:
            v += list(self.omega) + list(self.R.ravel())
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


def _rot2(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


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
        inertia = inertia + mass * (d @ d if dim == 2 else (d @ d) * np.eye(3) - np.outer(d, d))
        c = c + d
    if fl["inertia"] > 0:
        inertia = fl["inertia"]
    ca = fl["added_mass"] * rho0  # M_a = C_a rho0 V, I_a = C_a rho0 J (J: per unit density, about c)
    j_c = j if fl["centre"] is None else (j + vol * (d @ d if dim == 2 else (d @ d) * np.eye(3) - np.outer(d, d)))
    return FloatingBody(key, dim, mass, c, inertia, fl["release"], ca * vol, ca * j_c)
