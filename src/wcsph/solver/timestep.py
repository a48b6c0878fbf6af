"""The size of the next step: a constant ``time.dt``, or the stability conditions, which an
adaptive integrator may lower.

The conditions are the least of the CFL (sound speed plus flow speed), force (Monaghan 1992)
and viscous (Morris et al. 1997) limits: dt = min(cfl h/(c0 + |v|max), force_cfl
sqrt(h/|a|max), 0.125 h^2/nu), with ``vmax`` and ``amax`` the run state's, from the last
step's check."""
from ..errors import SimulationError


class TimeStep:
    def __init__(self, tc, cfl, integrator, nu):
        self.tc, self.cfl, self.integrator, self.nu = tc, cfl, integrator, nu

    def stable(self, state):
        """The stability conditions' step at the current state."""
        h = state.h
        dt = self.cfl * h / (state.c0 + state.vmax)
        if state.amax > 0:
            dt = min(dt, self.tc["force_cfl"] * (h / state.amax) ** 0.5)
        if self.nu > 0:
            dt = min(dt, 0.125 * h * h / self.nu)
        return dt

    def __call__(self, state):
        """The next step's size; falling below ``dtMin`` stops the run."""
        tc = self.tc
        if tc["dt"] > 0:
            return tc["dt"]
        if state.steps == 0 and tc["dtInit"] > 0:
            return tc["dtInit"]
        dt = self.integrator.propose(self.stable(state))
        if dt < tc["dtMin"]:
            raise SimulationError(f"time step {dt:.3g} s fell below time.dtMin = {tc['dtMin']:.3g} s at t = "
                                  f"{state.t:.6g} s (|v|max = {state.vmax:.3g} m/s, |a|max = {state.amax:.3g} m/s^2)")
        return dt
