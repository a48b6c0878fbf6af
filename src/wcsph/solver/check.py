"""Stage: the checks after a step, and the speeds the next step's size is taken from.

``measure`` leaves its figures in the state (``vmax``, ``amax``, ``bad``, ``n_owned``);
``verify`` reads them and stops the run with one line naming the step. A backend that keeps
the state on a device can measure every step and verify every few steps."""
import math

from ..errors import SimulationError


class Check:
    def __call__(self, state):
        self.measure(state)
        self.verify(state)

    @staticmethod
    def measure(state):
        be, par = state.backend, state.par
        if par is None:
            n = state.fluid.n
            vmax2, amax2, bad = be.check(state.fluid)
        else:  # over every rank's own particles: every rank takes the same step next
            vmax2, amax2, bad = be.check(state.fluid, state.fluid["owned"])
            vmax2, amax2 = par.max([vmax2, amax2])
            bad, n = (int(c) for c in par.sum([bad, par.n_owned]))
        state.vmax, state.amax, state.bad, state.n_owned = math.sqrt(vmax2), math.sqrt(amax2), bad, n

    @staticmethod
    def verify(state):
        where = f"t = {state.t:.6g} s (step {state.steps})"
        if state.n_owned == 0:
            raise SimulationError(f"every fluid particle has left the domain by {where}; "
                                  "enlarge [domain] or close the tank")
        if state.bad:
            raise SimulationError(f"{state.bad} fluid particles have a non-finite position, velocity or "
                                  f"acceleration at {where}: the run blew up")
        if state.vmax > state.c0:
            raise SimulationError(f"runaway velocity {state.vmax:.3g} m/s exceeds the speed of sound "
                                  f"{state.c0:.3g} m/s at {where}")
