"""Stage: the checks after a step, and the speeds the next step's size is taken from.

``measure`` leaves its figures in the state (``vmax``, ``amax``, ``bad``, ``n_owned``);
``verify`` reads them and stops the run with one line naming the step.

**Read every few steps.** A backend that keeps the state on a device (``defers_check``)
can measure each step into a ring of rows on the device and leave the host to read the ring
every ``every`` steps (``defer``): one copy to the host per ``every`` steps instead of one a
step, and no wait for the device between them. The rows are verified in step order, so an
error still names the first bad step and its time. Only where nothing needs the figures
between reads: a constant time step (an adaptive one is made from them), one process, no
open boundary or floating body, no choice that reads the step's largest speed (``speed``).
The time loop reads the ring before it looks at the state (an output, a checkpoint, the
end, a signal: ``read``). A particle that leaves the grid between reads stays in the arrays,
parked beyond the grid where no neighbour walk meets it, and is dropped at the read."""
import math

from ..errors import SimulationError


class Check:
    def __init__(self):
        self.every = 1
        self.pending = []  # (steps, t, particles) of each row measured and not read yet

    def defer(self, every):
        """Read the device's figures every ``every`` steps from now on (1: every step)."""
        self.every = every

    def __call__(self, state):
        if self.every > 1 and state.fluid.n:
            state.backend.check_later(state.fluid, len(self.pending), self.every)
            self.pending.append((state.steps, state.t, state.fluid.n))
            if len(self.pending) == self.every:
                self.read(state)
            return
        self.read(state)
        self.measure(state)
        self.verify(state)

    def read(self, state):
        """The rows measured since the last read, verified in step order; the particles they
        found outside the grid dropped."""
        if not self.pending:
            return
        pending, self.pending = self.pending, []
        left = False
        for (steps, t, n), (vmax2, amax2, bad, outside) in zip(pending, state.backend.read_checks(state.fluid,
                                                                                               len(pending))):
            state.vmax, state.amax, state.bad, state.n_owned = math.sqrt(vmax2), math.sqrt(amax2), bad, n - outside
            self.verify(state, steps, t)
            left = left or outside > 0
        if left:  # a sort that reads the count drops them (the next sort would find the same order)
            state.dropped += state.backend.sort(state.fluid, state.grid)

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
    def verify(state, steps=None, t=None):
        """Stop on a non-physical state; ``steps`` and ``t`` those of the figures (the state's
        own when not given)."""
        steps = state.steps if steps is None else steps
        t = state.t if t is None else t
        where = f"t = {t:.6g} s (step {steps})"
        if state.n_owned == 0:
            raise SimulationError(f"every fluid particle has left the domain by {where}; "
                                  "enlarge [domain] or close the tank")
        if state.bad:
            raise SimulationError(f"{state.bad} fluid particles have a non-finite position, velocity or "
                                  f"acceleration at {where}: the run blew up")
        if state.vmax > state.c0:
            raise SimulationError(f"runaway velocity {state.vmax:.3g} m/s exceeds the speed of sound "
                                  f"{state.c0:.3g} m/s at {where}")
