"""Stage: the model's corrections after a step (wall bounce, shifting, density filters:
whatever its choices declare as after-step passes)."""


class Correct:
    def __call__(self, state):
        settle = state.settle if state.par is not None else None
        state.model.correct(state.fluid, state.walls, state.P, state.G, state.steps + 1, settle=settle)
