"""Stage: the checks after a step, and the speeds the next step's size is taken from.

``measure`` leaves its figures in the state (``vmax``, ``amax``, ``bad``, ``n_owned``);
``verify`` reads them and stops the run with one line naming the step.

**Read every few steps.** A backend that keeps the state on a device (``defers_check``)
can measure each step into a ring of rows on the device and leave the host to read the ring
every ``every`` steps (``defer``): one copy to the host per ``every`` steps instead of one a
step, and no wait for the device between them. The copy is asynchronous and its rows are
verified a read later (``read_ahead``): the host never waits for the steps it has just
queued. The rows are verified in step order, so an error still names the first bad step
and its time (found up to two reads after it). Only where nothing on the host needs the figures
between reads: a constant time step, or an adaptive one that the device makes from them
(``solver.timestep``: each row then holds the step's size too, and the read sums the time),
one process, no open boundary or floating body, no choice that reads the step's largest
speed (``speed``).
The time loop reads the ring before it looks at the state (an output, a checkpoint, the
end, a signal: ``read``). A particle that leaves the grid between reads stays in the arrays,
parked beyond the grid where no neighbour walk meets it, and is dropped at the read."""
import math

from ..errors import SimulationError
from .timestep import too_small


class Check:
    def __init__(self, dt_min=0.0):
        self.every = 1
        self.dt_min = dt_min  # ``time.dtMin``: a step the device made shorter stops the run at the read
        self.pending = []  # (steps, t, particles, sized on the device) of each row measured and not read yet
        self.in_flight = None  # (pending, the backend's read, its lead): rows on their way to the host
        self.last = None  # the ring's row of the last step's check (read or not): a device sizes the next from it

    def defer(self, every):
        """Read the device's figures every ``every`` steps from now on (1: every step)."""
        self.every = every

    def __call__(self, state):
        if self.every > 1 and state.fluid.n:
            self.last = len(self.pending)
            state.backend.check_later(state.fluid, self.last, self.every)
            self.pending.append((state.steps, state.t, state.fluid.n, state.dt is None))
            if len(self.pending) == self.every:
                self.read_ahead(state)
            return
        self.read(state)
        self.last = None
        self.measure(state)
        self.verify(state)

    def read_ahead(self, state):
        """The rows measured since the last read start on their way to the host, and the rows
        started the read before are verified: the host waits only for the device's work
        queued before those (a read behind, the device is never left without a queue)."""
        lead = state.lead - (self.in_flight[2] if self.in_flight else 0.0)
        previous = self.in_flight
        self.in_flight = (self.pending, state.backend.start_read(state.fluid, len(self.pending)), lead)
        self.pending = []
        if previous is not None:
            self.finish(state, *previous)

    def read(self, state):
        """Every row measured and not verified yet (those on their way first): the host's
        state is then the device's."""
        if self.in_flight is not None:
            previous, self.in_flight = self.in_flight, None
            self.finish(state, *previous)
        if self.pending:
            pending, self.pending = self.pending, []
            self.finish(state, pending, state.backend.start_read(state.fluid, len(pending)), state.lead)

    def finish(self, state, pending, handle, lead):
        """The rows of one read, verified in step order; the particles they found outside the
        grid dropped. Steps the device sized move the time on by the sizes read (the host's
        sum of the same numbers; ``lead`` bounded them); one shorter than ``time.dtMin`` stops
        the run as the host's rule would."""
        rows = state.backend.finish_read(state.fluid, handle)
        times, t = [], state.t
        for (_, t_host, _, on_device), row in zip(pending, rows):
            t = t + row[4] if on_device else t_host
            times.append(t)
        start, state.t = state.t, times[-1]
        newest = self.in_flight is None and not self.pending
        state.lead = 0.0 if newest else max(state.lead - lead, 0.0)
        if pending[-1][3] and newest:  # the last step's size and parameters, as the host would have them
            state.dt = rows[-1][4]
            state.P = state.params_for(state.dt)
        left = False
        for (steps, _, n, on_device), (vmax2, amax2, bad, outside, dt), t in zip(pending, rows, times):
            if on_device:  # made from the row before (the state's speeds here) at the step's start
                too_small(dt, self.dt_min, start, state.vmax, state.amax)
            state.vmax, state.amax, state.bad, state.n_owned = math.sqrt(vmax2), math.sqrt(amax2), bad, n - outside
            self.verify(state, steps, t)
            left = left or outside > 0
            start = t
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
