"""Stage: the floating bodies' rigid-body step (``floating``), after the fluid's: the fluid's
force and torque on each at the step's end (``solver.loads``) and gravity move it by the step's
dt; floating boxes that met each other or an obstacle on its path (``floating.Driven``) are
parted (``floating.collide``) and put back inside the tank;
``MoveWalls`` then places its walls."""
from ..boundaries.floating import collide
from .loads import loads

#: sweeps over the pairs of floating bodies at most, per step: a stack of bodies on the floor
#: passes each push on to the floor through the others, a part per sweep
SWEEPS = 16


class MoveBodies:
    def __init__(self, bodies):
        self.bodies = bodies
        self.which = sorted(bodies.floating)

    def __call__(self, state):
        g = state.gravity * state.gravity_factor(state.t)
        for b, (force, torque) in zip(self.which, loads(state, self.bodies, self.which)):
            self.bodies.floating[b].step(state.dt, force, torque, g, state.t)
        moving = [self.bodies.floating[b] for b in self.which]
        driven = [d.at(state.t) for d in self.bodies.driven]  # obstacles on their paths, now
        pairs = [(a, b) for i, a in enumerate(moving) for b in moving[i + 1:] + driven]
        for _ in range(SWEEPS if pairs else 0):  # Gauss-Seidel sweeps over the pairs
            touched = False
            for a, b in pairs:
                if collide(a, b):
                    touched = True
                    for body in (a, b):  # a push must not take a body through the tank or an obstacle
                        if body not in driven:
                            body.settle()
            if not touched:
                break
