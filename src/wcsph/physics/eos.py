"""Equations of state p(rho), and their inverses rho(p) where a term needs one. Slot ``EOS``.

Each choice's ``build(ctx, q)`` returns ``(pressure, density, sound)``: p(rho), its inverse
rho(p) and the sound speed c(rho) = sqrt(dp/drho), jitable functions of (value, P).
"""
import math

from numba.extending import register_jitable

from .registry import POS, Choice, Param, add

GAMMA = Param("gamma", 7.0, "exponent of the Tait and Cole equations of state", check=POS, table="physics")
CLAMP = Param("clamp_negative_pressure", True, "clip p at zero (SPlisHSPlasH does so with density summation: "
              "the deficit at a free surface would otherwise pull particles together)", kind="bool")
COEF_B = Param("coefB", 0.0, "B of the Cole EOS; 0: c0^2 rho0 / gamma", unit="Pa", check=(lambda v: v >= 0, "must "
               "be zero or positive"), spec=True)


def make_tait(ctx, clamp_negative):
    """Tait EOS p = kappa rho0 / gamma ((rho/rho0)^gamma - 1) of Becker & Teschner (2007)
    (Monaghan 1994 with B = c0^2 rho0 / gamma, kappa = c0^2). The third spec prints
    c0^2 rho0 (rho/rho0)^gamma; this is the usual form with its 1/gamma and its -1, so that
    p(rho0) = 0 and dp/drho(rho0) = c0^2. With ``clamp_negative`` p >= 0. ``P.eos_b`` =
    kappa rho0/gamma."""
    one, zero = ctx.dtype(1), ctx.zero

    @register_jitable
    def pressure(rho, P):
        p = P.eos_b * ((rho * P.rho0_inv) ** P.gamma - one)
        if clamp_negative:
            p = max(p, zero)
        return p

    @register_jitable
    def density(p, P):
        return P.rho0 * (one + p / P.eos_b) ** P.gamma_inv

    return pressure, density, make_power_sound(ctx)


def make_cole(ctx):
    """Cole (1948) EOS, p = p0 + B ((rho/rho0)^gamma - 1), B = ``coefB`` (default
    c0^2 rho0/gamma, Monaghan 1994), and its inverse rho = rho0 (1 + (p - p0)/B)^(1/gamma).
    ``P.eos_b`` = B, ``P.gamma``, ``P.gamma_inv``, ``P.p0``."""
    one = ctx.dtype(1)

    @register_jitable
    def pressure(rho, P):
        return P.p0 + P.eos_b * ((rho * P.rho0_inv) ** P.gamma - one)

    @register_jitable
    def density(p, P):
        return P.rho0 * (one + (p - P.p0) / P.eos_b) ** P.gamma_inv

    return pressure, density, make_power_sound(ctx)


def make_linearized_cole(ctx):
    """Cole EOS linearized about rho0: p = p0 + c0^2 (rho - rho0), the form the WCSPH-BI
    schemes are written with; inverse rho = rho0 + (p - p0)/c0^2. ``P.c2`` = c0^2."""

    @register_jitable
    def pressure(rho, P):
        return P.p0 + P.c2 * (rho - P.rho0)

    @register_jitable
    def density(p, P):
        return P.rho0 + (p - P.p0) / P.c2

    @register_jitable
    def sound(rho, P):
        return math.sqrt(P.c2)

    return pressure, density, sound


def make_power_sound(ctx):
    """c(rho) = sqrt(gamma B / rho0 (rho/rho0)^(gamma - 1)) of p = B (rho/rho0)^gamma + const."""
    one = ctx.dtype(1)

    @register_jitable
    def sound(rho, P):
        return math.sqrt(P.gamma * P.eos_b * P.rho0_inv * (rho * P.rho0_inv) ** (P.gamma - one))

    return sound


def _gamma(q):
    g = q.ph["gamma"]
    return {"gamma": g, "gamma_inv": 1.0 / g}


add("eos", Choice(
    "TaitEquationOfState", "Becker & Teschner (2007) eq. 7; Monaghan (1994)",
    "p = c0^2 rho0/gamma ((rho/rho0)^gamma - 1), clipped at 0 unless clamp_negative_pressure = false",
    params=(GAMMA, CLAMP), p_fields=("eos_b", "gamma", "gamma_inv"),
    values=lambda q: dict(_gamma(q), eos_b=q.c0 ** 2 * q.rho0 / q.ph["gamma"]),
    build=lambda ctx, q: make_tait(ctx, q.m["clamp_negative_pressure"])))
add("eos", Choice(
    "ColeEquationOfState", "WCSPH-BI spec (Cole 1948)", "p = p0 + B ((rho/rho0)^gamma - 1), B = coefB or c0^2 rho0/gamma",
    params=(GAMMA, COEF_B), p_fields=("eos_b", "gamma", "gamma_inv"),
    values=lambda q: dict(_gamma(q), eos_b=q.m["coefB"] or q.c0 ** 2 * q.rho0 / q.ph["gamma"]),
    build=lambda ctx, q: make_cole(ctx)))
add("eos", Choice(
    "LinearizedColeEquationOfState", "WCSPH-BI spec", "p = p0 + c0^2 (rho - rho0)",
    build=lambda ctx, q: make_linearized_cole(ctx)))
