"""Moving walls to where their motion puts them (``motion.Bodies``).

A wall on a prescribed path is where it is at the time of the state that reads it: each of
an integrator's evaluations places it at that evaluation's time (``State.evaluate``: the
predictor's at the step's start, a midpoint's at its middle), and ``WallsAtStepEnd`` places
it at the step's end before the after-step passes, so that the elastic bounce and NBVC-PST
keep the particles off the wall where it then is. (With the walls held at the step's start
through the step and its corrections, a moving body's face lagged the fluid by about half a
step: in SPHERIC test 6 a single step of another size set the drag ringing by +-30 %, and
the steps clipped onto the 0.05 s sample times read the mean drag 22 % low; docs/accuracy.md.)
A floating body moves once, after the fluid's step (``solver.floating``); ``MoveWalls`` then
places its walls.
"""
from ..boundaries.motion import WallPlacement, make_place
from ..errors import SimulationError


def place_walls(state, bodies, t):
    """Moving walls to their position, normal, velocity and acceleration at time t, then wrapped and
    sorted; nothing when every wall is fixed. The bodies' poses are made on the host (a row
    each) and the points placed by a map of the backend's (``motion.make_place``): on a GPU
    the walls stay there, and only the poses travel."""
    if not bodies.moving:
        return
    state.walls_t = t
    be, w = state.backend, state.walls
    normals = "n0" in w.arrays
    placer = state.__dict__.get("_placer")
    if placer is None:
        placer = state.__dict__["_placer"] = be.make_map(make_place(state.dim, normals))
    a = w.arrays
    x0 = a["x0"]
    poses = bodies.poses(t)
    placer(WallPlacement(x0, a["n0"] if normals else x0, a["body"], be.stage("poses", poses), a["x"],
                         a["n"] if normals else a["x"], a["v"], a["a"]), state.P)
    be.wrap(w, state.grid)
    # where the bodies' bounds show every point inside the grid, the sort need not count
    # them (on a GPU: no read of the device)
    lost = be.sort(w, state.grid, inside=state.grid.holds(*bodies.bounds(poses)))
    if lost:
        raise SimulationError(f"{lost} wall points of a moving body left the domain at t = {t:.6g} s; "
                              "enlarge [domain] or change the motion")


def clock(state, bodies):
    """``state.walls_at``: walls on prescribed paths to time t (unless there already);
    None when no wall has a prescribed path."""
    if not bodies.prescribed:
        return None

    def walls_at(t):
        if t != state.walls_t:
            place_walls(state, bodies, t)

    return walls_at


class WallsAtStepEnd:
    """Stage: walls on prescribed paths where they are at the step's end, for the
    after-step passes."""

    def __call__(self, state):
        if state.walls_at is not None:
            state.walls_at(state.t + state.dt)


class MoveWalls:
    """Stage: every moving wall where it is at the (advanced) time: a floating body's after
    its step; also what a restart calls."""

    def __init__(self, bodies):
        self.bodies = bodies

    def __call__(self, state):
        place_walls(state, self.bodies, state.t)
