"""Equations of state p(rho), and their inverses rho(p) where a term needs one."""
from numba.extending import register_jitable


def make_tait(dtype, clamp_negative):
    """Tait EOS p = kappa rho0 / gamma ((rho/rho0)^gamma - 1) of Becker & Teschner (2007)
    (Monaghan 1994 with B = c0^2 rho0 / gamma, kappa = c0^2). ``P.eos_b`` = kappa rho0/gamma.

    With ``clamp_negative`` the pressure is clipped at zero, as SPlisHSPlasH does with density
    summation: the density deficit at a free surface would otherwise pull particles together.
    """
    one, zero = dtype(1), dtype(0)

    @register_jitable
    def eos(rho, P):
        p = P.eos_b * ((rho * P.rho0_inv) ** P.gamma - one)
        if clamp_negative:
            p = max(p, zero)
        return p

    return eos


def make_cole(dtype):
    """Cole (1948) EOS, p = p0 + B ((rho/rho0)^gamma - 1), B = ``coefB`` (default
    c0^2 rho0/gamma, Monaghan 1994), and its inverse rho = rho0 (1 + (p - p0)/B)^(1/gamma).
    ``P.eos_b`` = B, ``P.gamma``, ``P.gamma_inv``, ``P.p0``."""
    one = dtype(1)

    @register_jitable
    def pressure(rho, P):
        return P.p0 + P.eos_b * ((rho * P.rho0_inv) ** P.gamma - one)

    @register_jitable
    def density(p, P):
        return P.rho0 * (one + (p - P.p0) / P.eos_b) ** P.gamma_inv

    return pressure, density


def make_linearized_cole(dtype):
    """Cole EOS linearized about rho0: p = p0 + c0^2 (rho - rho0), the form the WCSPH-BI
    schemes are written with; inverse rho = rho0 + (p - p0)/c0^2. ``P.c2`` = c0^2."""

    @register_jitable
    def pressure(rho, P):
        return P.p0 + P.c2 * (rho - P.rho0)

    @register_jitable
    def density(p, P):
        return P.rho0 + (p - P.p0) / P.c2

    return pressure, density


COLE = {"ColeEquationOfState": make_cole, "LinearizedColeEquationOfState": make_linearized_cole}
