"""Potential flow references: the added mass of a 2D body in a closed tank.

A body accelerated through still, inviscid, incompressible fluid feels the force -m_a a. Its
added mass m_a = rho int_body phi n_x ds, phi the potential of the body moving at unit
velocity along x (dphi/dn = n_x on the body, 0 on the tank's walls) and n the normal out of
the fluid into the body. It is solved here with constant-strength source panels (Hess & Smith
1967): each side of the body's polygon and of the tank's box cut into panels, the normal
velocity matched at every panel's midpoint. A circle of radius R alone has m_a = rho pi R^2;
inside a concentric circle of radius b, rho pi R^2 (b^2 + R^2) / (b^2 - R^2).
"""
import numpy as np


def _panels(outline, n_per_side, fluid_left):
    """(start, end, normal into the fluid) of the panels of a closed polyline (the last point
    joins the first); the fluid lies left of the direction of travel if ``fluid_left``."""
    pts = np.asarray(outline, dtype=float)
    a, b = pts, np.roll(pts, -1, axis=0)
    s = np.linspace(0.0, 1.0, n_per_side + 1)
    p0 = (a[:, None, :] + (b - a)[:, None, :] * s[None, :-1, None]).reshape(-1, 2)
    p1 = (a[:, None, :] + (b - a)[:, None, :] * s[None, 1:, None]).reshape(-1, 2)
    t = p1 - p0
    t /= np.hypot(t[:, 0], t[:, 1])[:, None]
    left = np.c_[-t[:, 1], t[:, 0]]
    return p0, p1, left if fluid_left else -left


def _signed_area(outline):
    p = np.asarray(outline, dtype=float)
    return 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))


def _added_mass(body, tank, rho, panel_length, gauss):
    a_list, b_list, n_list = [], [], []
    for outline, fluid_inside in ((body, False), (tank, True)):
        outline = np.asarray(outline, dtype=float)
        side = float(np.max(np.hypot(*(np.roll(outline, -1, axis=0) - outline).T)))
        ccw = _signed_area(outline) > 0
        p0, p1, nrm = _panels(outline, max(1, int(np.ceil(side / panel_length))), fluid_left=ccw == fluid_inside)
        a_list.append(p0), b_list.append(p1), n_list.append(nrm)
    a, b, nrm = np.concatenate(a_list), np.concatenate(b_list), np.concatenate(n_list)
    on_body = np.arange(len(a)) < len(a_list[0])
    length = np.hypot(*(b - a).T)
    mid = 0.5 * (a + b)
    g, wg = np.polynomial.legendre.leggauss(gauss)
    g, wg = 0.5 * (g + 1.0), 0.5 * wg
    n = len(a)
    vel_n, pot = np.empty((n, n)), np.empty((n, n))
    for j in range(n):  # panel j's unit source density at every midpoint: (1/2 pi) ln r
        q = a[j] + (b[j] - a[j]) * g[:, None]
        d = mid[:, None, :] - q[None, :, :]
        r2 = np.sum(d * d, axis=-1)
        r2[j] = 1.0
        vel = np.sum(d / r2[..., None] * wg[None, :, None], axis=1) * length[j] / (2 * np.pi)
        vel_n[:, j] = np.sum(vel * nrm, axis=1)
        pot[:, j] = np.sum(0.5 * np.log(r2) * wg[None, :], axis=1) * length[j] / (2 * np.pi)
        vel_n[j, j] = 0.5  # its own side: half the source's outflow, into the fluid
        pot[j, j] = length[j] * (np.log(0.5 * length[j]) - 1.0) / (2 * np.pi)
    out = []
    for axis in (0, 1):
        rhs = np.where(on_body, nrm[:, axis], 0.0)  # dphi/dn = U . n at the body, 0 at the tank
        sigma = np.linalg.lstsq(vel_n, rhs, rcond=None)[0]  # the closed tank's system has a null space
        phi = pot @ sigma
        out.append(-rho * np.sum(phi[on_body] * nrm[on_body, axis] * length[on_body]))
    return np.array(out)


def added_mass_2d(body, tank, rho=1000.0, panel_length=0.04, gauss=8):
    """(m_x, m_y): the added mass [kg per m of width] of the closed polygon ``body`` moving
    along x and along y inside the closed polygon ``tank`` (points of either in either
    order; a box: its four corners), by source panels of at most ``panel_length`` and of half
    that, extrapolated to zero length (the panels' error is first order in their length)."""
    coarse = _added_mass(body, tank, rho, panel_length, gauss)
    fine = _added_mass(body, tank, rho, 0.5 * panel_length, gauss)
    return tuple(2.0 * fine - coarse)
