"""Stage: moving walls to where their motion puts them (``motion.Bodies``)."""
from ..errors import SimulationError


def place_walls(state, bodies, t):
    """Moving walls to their position, normal, velocity and acceleration at time t, then wrapped and
    sorted; nothing when every wall is fixed."""
    if not bodies.moving:
        return
    be, w, dtype = state.backend, state.walls, state.dtype
    x0, body = state.host(w, "x0", "body")
    n0 = be.to_host(w["n0"]) if "n0" in w.arrays else None
    x, n, v, a = bodies.place(t, x0.astype(float), None if n0 is None else n0.astype(float), body)
    w["x"] = be.to_device(x.astype(dtype))
    w["v"] = be.to_device(v.astype(dtype))
    w["a"] = be.to_device(a.astype(dtype))
    if n is not None:
        w["n"] = be.to_device(n.astype(dtype))
    be.wrap(w, state.grid)
    lost = be.sort(w, state.grid)
    if lost:
        raise SimulationError(f"{lost} wall points of a moving body left the domain at t = {t:.6g} s; "
                              "enlarge [domain] or change the motion")


class MoveWalls:
    """The walls where they are at the step's end time (for the output and the next step):
    a step's other stages see them where they were at its start."""

    def __init__(self, bodies):
        self.bodies = bodies

    def __call__(self, state):
        place_walls(state, self.bodies, state.t)
