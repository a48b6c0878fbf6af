"""Stage: the particles sorted by cell, once per step.

The neighbour cells of the step's first state serve its later evaluations too: they move
the particles by far less than a cell. In a decomposed run the ghosts are dropped, the
particles that crossed a cut migrate (and the cuts move when the load is uneven), and the
new ghosts arrive before the sort."""


class Sort:
    def __call__(self, state):
        if state.par is None:
            state.dropped += state.backend.sort(state.fluid, state.grid)
        else:
            state.dropped += state.par.redistribute(state.fluid)
