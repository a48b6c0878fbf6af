"""The size of the next step: a constant ``time.dt``, or the stability conditions, which an
adaptive integrator may lower.

The conditions are the least of the CFL (sound speed plus flow speed), force (Monaghan 1992)
and viscous (Morris et al. 1997) limits: dt = min(cfl h/(c0 + |v|max), force_cfl
sqrt(h/|a|max), 0.125 h^2/nu), with ``vmax`` and ``amax`` the run state's, from the last
step's check (``stable_step``, one function for the host and the device).

**Sized on the device.** Where the host reads the checks every few steps (``solver.check``)
and the step is the stability conditions' as they are (``solver.simulation.size_on_device``,
set with ``size_on_device`` here), a device makes each
step's size itself from the last step's check, still on the device, and writes it into the
step's parameters there, with P's fields made from it (``slots.step_value``): the host then launches step after step without waiting for the
device, and learns the sizes, and the time, at the next read. The host calls for a read
before the time could reach an output or the end: each step is at most ``bound`` (the CFL
limit at rest), so it steps on without reading while t + (steps not read) bound stays short
of them. The time summed from the sizes read is the one the host would have summed."""
import math

from ..errors import SimulationError
from ..physics.slots import step_value


def stable_step(vmax, amax, cfl, h, c0, force_cfl, nu):
    """The stability conditions' step for largest speed ``vmax`` and acceleration ``amax``
    (jitable: the host's rule and a device's are this one function)."""
    dt = cfl * h / (c0 + vmax)
    if amax > 0:
        dt = min(dt, force_cfl * math.sqrt(h / amax))
    if nu > 0:
        dt = min(dt, 0.125 * h * h / nu)
    return dt


#: P's dt while a step's size is made on the device (the device overwrites it in P's record)
ON_DEVICE = -1.0


def too_small(dt, dt_min, t, vmax, amax):
    """Stop the run when a step ``dt`` made from ``vmax`` and ``amax`` at time ``t`` falls below
    ``time.dtMin``."""
    if dt < dt_min:
        raise SimulationError(f"time step {dt:.3g} s fell below time.dtMin = {dt_min:.3g} s at t = "
                              f"{t:.6g} s (|v|max = {vmax:.3g} m/s, |a|max = {amax:.3g} m/s^2)")


class TimeStep:
    def __init__(self, tc, cfl, integrator, nu):
        self.tc, self.cfl, self.integrator, self.nu = tc, cfl, integrator, nu
        self.check = None  # the check stage whose rows a device sizes steps from (``size_on_device``)

    def size_on_device(self, check):
        """Make each step's size on the device from the last row of ``check``'s ring, when the
        host has not read it yet (``check`` defers its reads)."""
        self.check = check

    def constants(self, state):
        """(cfl, h, c0, force_cfl, nu): ``stable_step``'s arguments besides the speeds."""
        return self.cfl, state.h, state.c0, self.tc["force_cfl"], self.nu

    def bound(self, state):
        """No step is longer than this: the CFL limit at rest, a hair over for the rounding of dt
        to the case's precision."""
        return stable_step(0.0, 0.0, *self.constants(state)) * (1.0 + 2.0 ** -20)

    def stable(self, state):
        """The stability conditions' step at the current state."""
        return stable_step(state.vmax, state.amax, *self.constants(state))

    def __call__(self, state):
        """The next step's size; falling below ``dtMin`` stops the run. None: the device makes
        it from the last check's row on its ring (the parameters stage launches that,
        ``parameters``), read by the host or not."""
        tc = self.tc
        if tc["dt"] > 0:
            return tc["dt"]
        if state.steps == 0 and tc["dtInit"] > 0:
            return tc["dtInit"]
        if self.check is not None and self.check.last is not None:
            if state.gravity_factor(state.t) == 1.0:  # P is the device's to finish: no ramp
                state.dt_bound = self.bound(state)
                return None
            self.check.read(state)
        dt = self.integrator.propose(self.stable(state))
        too_small(dt, tc["dtMin"], state.t, state.vmax, state.amax)
        return dt

    def parameters(self, state):
        """Stage: the step's parameters ``state.P`` for ``state.dt``; for a size the device makes
        (None), P with ``ON_DEVICE`` for dt, and the device's sizing launched into P's record."""
        if state.dt is not None:
            state.P = state.params_for(state.dt)
            return
        state.P = state.params_for(ON_DEVICE, vmax=0.0)  # the same P each step: one upload
        state.backend.size_step(state.fluid, self.check.last, len(self.check.pending), state.P, self.constants(state),
                                stable_step, state.model.stepped_values(), step_value)
