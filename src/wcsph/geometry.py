"""Particles from the case geometry: fluid blocks, tank walls and box obstacles.

Fluid particles sit on a lattice of spacing dp, dp/2 inside the block faces. Wall particles
sit on the same lattice continued beyond the wall surface (the tank's inner faces, an
obstacle's faces), ``layers`` deep, so fluid and wall particles start dp apart everywhere.
The last axis is vertical.
"""
import math

import numpy as np

from .config import CaseError
from .kernels import SUPPORT


def lattice(lo, hi, dp):
    """Points lo + dp/2 + k dp inside the box [lo, hi], as a (dim, N) array."""
    axes = []
    for a, b in zip(lo, hi):
        n = int(math.floor((b - a) / dp + 1e-6))
        axes.append(a + dp * (0.5 + np.arange(n)))
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh]) if axes else np.zeros((0, 0))


def wall_layers(case):
    layers = case["model"]["wall_layers"]
    if layers == 0 and case["model"]["wall_volume"] == "akinci":
        layers = 1  # the sampling Akinci's volume formula is made for
    elif layers == 0:
        layers = math.ceil(SUPPORT * case["model"]["smoothing_ratio"] - 1e-9)
    return layers


def _inside(x, lo, hi, tol=0.0):
    lo = np.asarray(lo)[:, None] + tol
    hi = np.asarray(hi)[:, None] - tol
    return np.all((x > lo) & (x < hi), axis=0)


def tank_particles(tank, dp, layers):
    lo = np.asarray(tank["min"], dtype=float)
    hi = np.asarray(tank["max"], dtype=float)
    t = layers * dp
    outer_hi = hi + t
    if tank["open_top"]:
        outer_hi[-1] = hi[-1]
    pts = lattice(lo - t, outer_hi, dp)
    interior_hi = hi.copy()
    if tank["open_top"]:
        interior_hi[-1] = hi[-1] + dp  # no lid
    return pts[:, ~_inside(pts, lo, interior_hi)]


def obstacle_particles(box, dp, layers):
    """A solid box, sampled ``layers`` deep from its faces (its core is never reached)."""
    lo = np.asarray(box["min"], dtype=float)
    hi = np.asarray(box["max"], dtype=float)
    pts = lattice(lo, hi, dp)
    return pts[:, ~_inside(pts, lo + layers * dp, hi - layers * dp)]


def build(case):
    """Fluid positions and velocities, wall positions, and the domain box of ``case``."""
    src, dp, dim = case["_source"], case["dp"], case["dim"]
    layers = wall_layers(case)
    walls = []
    if case["tank"] is not None:
        walls.append(tank_particles(case["tank"], dp, layers))
    for box in case["obstacle"]:
        walls.append(obstacle_particles(box, dp, layers))
    walls = np.concatenate(walls, axis=1) if walls else np.zeros((dim, 0))

    xs, vs = [], []
    for k, block in enumerate(case["fluid"]):
        if case["tank"] is not None:
            t = case["tank"]
            top = math.inf if t["open_top"] else t["max"][-1]
            for a in range(dim):
                hi_a = top if a == dim - 1 else t["max"][a]
                if block["min"][a] < t["min"][a] - 1e-9 * dp or block["max"][a] > hi_a + 1e-9 * dp:
                    raise CaseError(f"{src}: fluid[{k}]: block reaches into the tank wall on axis {a} "
                                    f"(tank interior is {t['min']} .. {t['max']})")
        x = lattice(block["min"], block["max"], dp)
        if x.shape[1] == 0:
            raise CaseError(f"{src}: fluid[{k}]: block is thinner than dp = {dp}, it holds no particle")
        for box in case["obstacle"]:  # obstacles displace the fluid they overlap
            x = x[:, ~_inside(x, np.asarray(box["min"]) - 0.5 * dp, np.asarray(box["max"]) + 0.5 * dp)]
        v = block["velocity"] or [0.0] * dim
        xs.append(x)
        vs.append(np.repeat(np.asarray(v, dtype=float)[:, None], x.shape[1], axis=1))
    fluid_x = np.concatenate(xs, axis=1)
    fluid_v = np.concatenate(vs, axis=1)

    d = case["domain"]
    h = case["model"]["smoothing_ratio"] * dp
    if d is not None and d["min"] is not None:
        lo, hi = np.asarray(d["min"]), np.asarray(d["max"])
        outside = ~np.all((fluid_x >= lo[:, None]) & (fluid_x <= hi[:, None]), axis=0)
        if outside.any():
            p = fluid_x[:, np.argmax(outside)]
            raise CaseError(f"{src}: fluid: {int(outside.sum())} fluid particles lie outside the domain "
                            f"{list(lo)} .. {list(hi)}, e.g. at {np.round(p, 6).tolist()}")
        if walls.shape[1]:
            w_out = ~np.all((walls >= lo[:, None]) & (walls <= hi[:, None]), axis=0)
            if w_out.any():
                raise CaseError(f"{src}: domain: {int(w_out.sum())} wall particles lie outside the domain; "
                                "enlarge domain or leave it out to have it computed")
    else:
        allx = np.concatenate([fluid_x, walls], axis=1)
        lo = allx.min(axis=1) - SUPPORT * h
        hi = allx.max(axis=1) + SUPPORT * h
        hi[-1] += hi[-1] - lo[-1]  # head room for splashes
    return fluid_x, fluid_v, walls, lo, hi


def lattice_density_sum(kernel_w_np, dim, dp, h):
    """sum_j W(|x_i - x_j|) of a full lattice around one particle, for the mass that makes
    the summation density of the initial lattice equal rho0 exactly."""
    n = int(math.ceil(SUPPORT * h / dp)) + 1
    ax = np.arange(-n, n + 1) * dp
    r = np.sqrt(sum(m**2 for m in np.meshgrid(*([ax] * dim), indexing="ij")))
    return float(kernel_w_np(r).sum())
