"""Stage: the step's end. A particle that left through a periodic side re-enters at the
other; the time and the step count move on."""


class Advance:
    def __call__(self, state):
        state.backend.wrap(state.fluid, state.grid)
        state.t += state.dt
        state.steps += 1
