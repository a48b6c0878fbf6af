"""The fluid's force and torque on each named body, for probes.csv."""
import numpy as np



def body_columns(bodies, dim):
    """The probes.csv columns of the named bodies' loads."""
    cols = []
    for b, name in enumerate(bodies.names):
        if name:
            cols += [f"{name}_f{c}" for c in "xyz"[:dim]]
            cols += [f"{name}_torque"] if dim == 2 else [f"{name}_t{c}" for c in "xyz"]
            if b in bodies.floating:  # its state: centre, velocity, orientation, angular velocity
                cols += bodies.floating[b].columns(name)
    return cols


def body_loads(state, bodies):
    """Force and torque of the fluid on each named body: {NAME_fx, NAME_fy[, NAME_fz],
    NAME_torque (2D) or NAME_tx, NAME_ty, NAME_tz (3D)}, the torque about the body's
    centre.

    Boundary elements: the sum of the body's element loads (``physics.loads``: the wall's
    own pressure p_b n_b S_b and the reaction of the viscous wall term), the torque with
    each element's lever arm. Boundary particles: the sum of the body's wall-particle loads,
    each the reaction of the wall terms on its fluid neighbours (``physics.loads``: exactly
    the wall force the fluid feels), the torque with each wall particle's lever arm. One pass
    over the wall points either way."""
    named = [b for b, name in enumerate(bodies.names) if name]
    if not named:
        return {}
    out, dim = {}, state.dim
    for b, (force, torque) in zip(named, loads(state, bodies, named)):
        name = bodies.names[b]
        for a, c in enumerate("xyz"[:dim]):
            out[f"{name}_f{c}"] = float(force[a])
        if dim == 2:
            out[f"{name}_torque"] = float(np.ravel(torque)[0])
        else:
            for a, c in enumerate("xyz"):
                out[f"{name}_t{c}"] = float(torque[a])
        if b in bodies.floating:
            out.update(bodies.floating[b].values(name))
    return out


def loads(state, bodies, which):
    """(force, torque about the body's centre) of the fluid on each body of ``which`` (body
    indices), totals over the ranks of a decomposed run (see ``body_loads``)."""
    out = _wall_point_loads(state, bodies, which)
    par, dim = state.par, state.dim
    if par is not None:
        out = [tuple(np.split(par.sum(np.concatenate([f, np.ravel(t)])), [dim])) for f, t in out]
    return out


def _wall_point_loads(state, bodies, named):
    be, w, par = state.backend, state.walls, state.par
    state.settle()
    load = state.model.wall_loads(state.fluid, w, state.P, state.G)
    refs = np.zeros((len(named), 3))
    for r, b in enumerate(named):
        refs[r, :state.dim] = bodies.reference(b, state.t)
    if par is None:  # summed by the backend: on a GPU only the sums come to the host
        rows = np.full(len(bodies.names), -1, dtype=np.int64)
        rows[list(named)] = np.arange(len(named))
        sums = be.body_sums(w["x"], load, w["body"], rows, refs)
        return [(s[:state.dim].copy(), s[3:] if state.dim == 3 else s[5:]) for s in sums]
    load = be.to_host(load).astype(float)
    x, body = state.host(w, "x", "body")
    x = x.astype(float)
    # each element from the rank whose slab holds it (all its neighbours are there)
    load = load * (par.owner(par.column(x)) == par.rank)
    out = []
    for r, b in enumerate(named):
        sel = body == b
        f = load[:, sel]
        rr = x[:, sel] - refs[r, :state.dim, None]
        torque = [np.sum(rr[0] * f[1] - rr[1] * f[0])] if state.dim == 2 else np.cross(rr.T, f.T).sum(axis=0)
        out.append((f.sum(axis=1), np.asarray(torque)))
    return out
