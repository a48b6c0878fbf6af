"""Stage: the floating bodies' rigid-body step (``floating``), after the fluid's: the fluid's
force and torque on each at the step's end (``solver.loads``) and gravity move it by the step's
dt; floating boxes that met each other or an obstacle on its path (``floating.Driven``) are
parted (``floating.collide``) and put back inside the tank;
``MoveWalls`` then places its walls."""
from ..boundaries.floating import part
from .loads import loads


class MoveBodies:
    def __init__(self, bodies):
        self.bodies = bodies
        self.which = sorted(bodies.floating)

    def __call__(self, state):
        g = state.gravity * state.gravity_factor(state.t)
        for b, (force, torque) in zip(self.which, loads(state, self.bodies, self.which)):
            self.bodies.floating[b].step(state.dt, force, torque, g, state.t)
        part([self.bodies.floating[b] for b in self.which], [d.at(state.t) for d in self.bodies.driven])
