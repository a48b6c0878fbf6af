"""Stage: the model's passes after a step (DPC, XSPH on the positions, shifting, the CSPM
density re-initialisation, the wall bounce and NBVC-PST: what its choices declare; the last
two not again when the integrator's last map ran them, ``State.tail``)."""


class AfterStep:
    def __call__(self, state):
        settle = state.settle if state.par is not None else None
        state.model.after_step(state.fluid, state.walls, state.P, state.G, state.steps + 1, settle=settle,
                               corrected=state.corrected)
        state.corrected = False
