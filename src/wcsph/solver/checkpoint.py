"""Checkpoints: everything a restart needs to continue bit for bit, as one ``.npz``."""
import hashlib
import json
from pathlib import Path

import numpy as np

from ..errors import CaseError
from ..io import vtk
from ..version import __version__

#: the layout of checkpoint.npz; a checkpoint of another version is refused
CHECKPOINT_VERSION = 2


def case_fingerprint(case):
    """A hash of what determines a run's state: the case without its end time, step limit,
    output settings and source path (those may change on a restart)."""
    keep = {k: v for k, v in case.items() if not k.startswith("_") and k != "output"}
    keep["time"] = {k: v for k, v in case["time"].items() if k not in ("end", "max_steps")}
    return hashlib.sha256(json.dumps(keep, sort_keys=True, default=str).encode()).hexdigest()


def save(path, state, integrator, open_boundaries, output_state=None, bodies=None):
    """The checkpoint at ``path`` (written atomically): every per-particle array of the fluid,
    the time, the step count, the speeds the next time step is taken from, the integrator's
    carried scalars (Verlet's step count, RK45's next step, the midpoint's primed guess), the
    open boundaries', the floating bodies' and the output series' state. In a decomposed run one file of every
    rank's own particles, written by rank 0: it restarts on any number of ranks."""
    names = [k for k in state.fluid.per_particle() if k != "owned"]
    arrays = dict(zip(names, state.owned_host(*names)))
    dropped = state.dropped
    if state.par is not None:
        arrays = state.par.gather(arrays)
        dropped = int(state.par.sum([dropped])[0])
        if state.par.rank != 0:
            return
    case = state.case
    meta = {"format": "wcsph checkpoint", "version": CHECKPOINT_VERSION, "wcsph": __version__,
            "case": {k: v for k, v in case.items() if not k.startswith("_")},
            "fingerprint": case_fingerprint(case), "t": state.t, "steps": state.steps,
            "evaluations": state.evaluations, "dropped": dropped, "vmax": state.vmax, "amax": state.amax,
            "n": int(arrays["x"].shape[1]), "integrator": integrator.carried_state(), "output": output_state,
            "open_boundary": open_boundaries.carried_state() if open_boundaries is not None else None,
            "bodies": bodies.carried_state() if bodies is not None else {}}
    arrays = {f"fluid.{k}": a for k, a in arrays.items()}
    with vtk.atomic(path) as tmp:
        with open(tmp, "wb") as f:
            np.savez(f, meta=np.array(json.dumps(meta)), **arrays)


def read(path):
    """(meta, arrays) of a checkpoint; a CaseError when it is not one this version reads."""
    path = Path(path)
    if path.is_dir():
        path = path / "checkpoint.npz"
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {k.split(".", 1)[1]: data[k] for k in data.files if k.startswith("fluid.")}
    except FileNotFoundError:
        raise CaseError(f"{path}: no checkpoint there (runs write one at their end, at a clean stop "
                        "and every output.checkpoint_interval)") from None
    except (OSError, ValueError, KeyError) as e:
        raise CaseError(f"{path}: not a readable wcsph checkpoint ({e})") from None
    if meta.get("format") != "wcsph checkpoint" or meta.get("version") != CHECKPOINT_VERSION:
        raise CaseError(f"{path}: checkpoint format version {meta.get('version')!r}; this wcsph reads "
                        f"version {CHECKPOINT_VERSION}")
    return meta, arrays


def restore(state, integrator, open_boundaries, meta, arrays, source="checkpoint", bodies=None):
    """Continue from a checkpoint of the same case (``time.end``, ``time.max_steps`` and
    ``[output]`` may differ): the fluid, the scalars, the integrator's and the open
    boundaries' carried state. Returns the output series' state."""
    if meta["fingerprint"] != case_fingerprint(state.case):
        raise CaseError(f"{source}: the checkpoint is from another case or other settings "
                        f"(case {meta['case'].get('name')!r}); restart it with the case it was written by")
    be, fluid, par = state.backend, state.fluid, state.par
    for k in fluid.per_particle():
        if k not in arrays and k != "owned" and k not in fluid.scratch:
            raise CaseError(f"{source}: the checkpoint lacks the fluid field {k!r}")
    fluid.arrays.pop("owned", None)
    # a scratch field the checkpoint lacks (a decomposed run has no spare arrays for the
    # predictor, ``Integrator.fuse_first``) is written before it is read: only its size matters
    n = int(arrays["x"].shape[1])
    for k in fluid.per_particle():
        if k not in arrays and k != "owned":
            arrays[k] = np.zeros(fluid[k].shape[:-1] + (n,), dtype=fluid[k].dtype)
    if par is not None:  # any number of ranks: each keeps its own of the whole
        mine = par.split(arrays["x"])
        arrays = {k: a[..., mine] for k, a in arrays.items()}
    fluid.n = int(arrays["x"].shape[1])
    for k, a in arrays.items():
        fluid[k] = be.to_device(np.ascontiguousarray(a))
    for k in [k for k in fluid.arrays if k.startswith("_")]:
        del fluid.arrays[k]  # the sort's spare arrays, sized for the old count
    state.t, state.steps, state.evaluations = meta["t"], meta["steps"], meta["evaluations"]
    state.dropped, state.vmax, state.amax = meta["dropped"], meta["vmax"], meta["amax"]
    if par is not None:
        par.redistribute(fluid)
        if par.rank != 0:
            state.dropped = 0  # counted once, on rank 0
    integrator.restore(meta["integrator"])
    if open_boundaries is not None:
        open_boundaries.restore(meta["open_boundary"])
    if bodies is not None:
        bodies.restore(meta.get("bodies", {}))
    return meta["output"]
