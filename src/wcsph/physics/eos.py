"""Equations of state p(rho)."""
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
