"""Stage: the integrator's step, with the model's parameters for the step's size
(``TimeStep.parameters``)."""
from ..errors import IntegrationError, SimulationError


class Integrate:
    """The scheme's evaluations and maps with ``state.P``. An adaptive
    scheme may take a smaller step than offered: ``state.dt`` is then the one taken, and P
    is made again for it (the later stages read both)."""

    def __init__(self, integrator):
        self.integrator = integrator

    def __call__(self, state):
        try:
            dt = self.integrator.step(state, state.P)
        except IntegrationError as e:
            raise SimulationError(f"{e} at t = {state.t:.6g} s (step {state.steps})") from None
        if dt != float(state.P.dt):
            state.dt = dt
            state.P = state.params_for(dt)
