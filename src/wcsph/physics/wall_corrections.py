"""Corrections that keep fluid particles off boundary elements, applied after a time step
(after Cercos-Pita 2015, AQUAgpusph; WCSPH-BI spec). The pass visits the elements b near fluid
particle i with the accumulator (vx, vy, vz, sx, sy, sz): i's velocity and its position shift
so far, so that a correction made for one element is seen by the next (a particle near a flat
wall is bounced or shifted once, not once per element). A seventh slot carries the particle's
radius R_i, computed once per particle by ``make_init`` (a power per pair made the pass five
times slower).

An element acts on a particle whose projection on the element's plane lies within
r_box = ``r_boxFactor`` dp of its centre, and which is not further behind the plane than it
may be pushed back (``P.back`` = max(h_fac dp, 0.55 dp): the larger of the bounce distance and
a particle's radius, about dp/2); its distance from the wall is dist = -(x_i - x_b) . n_b (n_b
points out of the fluid). Behind the plane (dist < 0) only a particle over the element itself
(its projection within the element: S/2 of the centre in 2D, the square's half diagonal
sqrt(S/2) in 3D): round a convex corner, a particle beside the element and behind its plane is
over the next face, outside the body. (With the r_box reach there, the water flowing over the
top of SPHERIC 6's square within a spacing of its leading edge was bounced off the front face,
its velocity along the top reflected to 2 U - u, and pushed forward by NBVC-PST: the friction
on the square's sides came out with the wrong sign.)
"""
import math

from numba.extending import register_jitable


def make_wall_corrections(ctx, bounce, epsilon_bounce, shift):
    """``bounce``: elastic bounce. A particle approaching the element (v_n = (v_i - v_b) . n_b
    > 0) that would come closer than h_fac dp (``minimalDistanceFactor``) within the next step
    (dist - dt v_n <= h_fac dp) has its normal velocity reflected, v_i -= (1 + e) v_n n_b:
    e = 1 for the conservative bounce (kinetic energy kept), e = ``elasticFactor`` for the
    epsilon bounce.
    ``shift``: near-boundary volume-correction particle shifting (NBVC-PST): a particle closer
    to the wall than its own radius R_i = (m_i/rho_i)^(1/d) / 2 (TNL-SPH: half the side of the
    cell its volume fills, so the volume does not reach into the wall) is moved along n_b back
    to that distance."""
    dim, zero, one = ctx.dim, ctx.zero, ctx.dtype(1)
    quarter, half = ctx.dtype(0.25), ctx.dtype(0.5)

    @register_jitable
    def term(i, j, dx, dy, dz, r, I, J, P, acc):
        vx, vy, vz, sx, sy, sz, radius = acc
        rx, ry = dx + sx, dy + sy
        rz = dz + sz if dim == 3 else zero
        nx, ny = J.n[0, j], J.n[1, j]
        nz = J.n[2, j] if dim == 3 else zero
        d = rx * nx + ry * ny + rz * nz
        dist = -d
        lateral2 = rx * rx + ry * ry + rz * rz - d * d
        if dist < -P.back or lateral2 >= P.r_box2:
            return acc
        # behind the element's plane only over the element itself: beside it, round a convex
        # corner, the particle is outside the body (over the next face), not in the wall
        size = J.elementSize[j]
        if dist < zero and lateral2 > (quarter * size * size if dim == 2 else half * size):
            return acc
        if bounce:
            vbz = J.v[2, j] if dim == 3 else zero
            vn = (vx - J.v[0, j]) * nx + (vy - J.v[1, j]) * ny + (vz - vbz) * nz
            if vn > zero and dist - P.dt * vn <= P.min_dist:
                e = P.elastic if epsilon_bounce else one
                k = (one + e) * vn
                vx, vy, vz = vx - k * nx, vy - k * ny, vz - k * nz
        if shift and dist < radius:
            s = radius - dist
            sx, sy, sz = sx - s * nx, sy - s * ny, sz - s * nz
        return (vx, vy, vz, sx, sy, sz, radius)

    return term


def make_init(ctx):
    """The accumulator's start: i's velocity, no shift, and its radius
    R_i = (m_i/rho_i)^(1/d) / 2."""
    dim, zero, half, third = ctx.dim, ctx.zero, ctx.dtype(0.5), ctx.dtype(1.0 / 3.0)

    @register_jitable
    def init(i, I, P):
        vol = I.m[i] / I.rho[i]
        if dim == 3:
            return (I.v[0, i], I.v[1, i], I.v[2, i], zero, zero, zero, half * vol ** third)
        return (I.v[0, i], I.v[1, i], zero, zero, zero, zero, half * math.sqrt(vol))

    return init


def make_store(ctx):
    dim = ctx.dim

    @register_jitable
    def store(i, I, P, acc):
        I.v[0, i] = acc[0]
        I.v[1, i] = acc[1]
        I.x[0, i] += acc[3]
        I.x[1, i] += acc[4]
        if dim == 3:
            I.v[2, i] = acc[2]
            I.x[2, i] += acc[5]

    return store
