"""Stage: the step's end. A particle that left through a periodic side re-enters at the
other; the time and the step count move on. A step the device sized (``state.dt`` None)
moves the time on at the next read of the checks; until then ``state.lead`` bounds it."""


class Advance:
    def __call__(self, state):
        state.backend.wrap(state.fluid, state.grid)
        if state.dt is None:
            state.lead += state.dt_bound
        else:
            state.t += state.dt
        state.steps += 1
