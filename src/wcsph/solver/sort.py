"""Stage: the particles sorted by cell, once per step.

The neighbour cells of the step's first state serve its later evaluations too: they move
the particles by far less than a cell. In a decomposed run the ghosts are dropped, the
particles that crossed a cut migrate (and the cuts move when the load is uneven), and the
new ghosts arrive before the sort.

``refresh``: a continuity-density model's p and V of the step's start are made from the
sorted density by the sort itself (on a GPU in the launch that moves the fields), and the
step's first evaluation starts with the walls (``State.evaluate``). For an integrator whose
step opens with an evaluation, in a run with nothing between the sort and it that changes
the density (no open boundary)."""


class Sort:
    def __init__(self, refresh=False):
        self.refresh = refresh

    def __call__(self, state):
        if state.par is None:
            model = state.model
            refresh = (model.refresh_fn, model.initialize_map, model.refresh_view, state.P) if self.refresh else None
            state.dropped += state.backend.sort(state.fluid, state.grid, refresh=refresh)
            state.fresh = refresh is not None
        else:
            state.dropped += state.par.redistribute(state.fluid)
