"""Stage: the floating bodies' rigid-body step (``floating``), after the fluid's: the fluid's
force and torque on each at the step's end (``run.loads``) and gravity move it by the step's
dt; ``MoveWalls`` then places its walls."""
from .loads import loads


class MoveBodies:
    def __init__(self, bodies):
        self.bodies = bodies
        self.which = sorted(bodies.floating)

    def __call__(self, state):
        g = state.gravity * state.gravity_factor(state.t)
        for b, (force, torque) in zip(self.which, loads(state, self.bodies, self.which)):
            self.bodies.floating[b].step(state.dt, force, torque, g, state.t)
