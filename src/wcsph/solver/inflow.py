"""Stages: the open boundaries' buffers around the integrator (``open_boundary``).

Before the step the buffer particles' state is kept; after it the buffers are prescribed
again, and particles that crossed an inlet or outlet plane change role, enter or leave."""


class InflowBefore:
    def __init__(self, open_boundaries):
        self.open = open_boundaries

    def __call__(self, state):
        self.open.before(state)


class InflowAfter:
    def __init__(self, open_boundaries):
        self.open = open_boundaries

    def __call__(self, state):
        self.open.after(state, state.dt)
