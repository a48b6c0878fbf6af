"""Stage: the run's output, in one directory: VTK series (``fluid.pvd``, ``case.pvd``, with
``output.surface`` the free surface's ``surface.pvd``),
``probes.csv`` (energies, surge front, probes, body loads, the scheme's figures), ``steps.csv``
(per-step figures of schemes that have them), ``checkpoint.npz`` and ``run.json``."""
import json
import re

import numpy as np

from ..io import probes, surface, vtk
from ..io.grids import GridSampler
from ..errors import CaseError
from .loads import body_columns, body_loads


class Output:
    """VTK series, probes.csv and run.json in one directory. In a decomposed run each rank
    writes its piece of every frame (``fluid_NNNN_pR.vtu``) and rank 0 the ``.pvtu`` that
    joins them, the series and the tables; a file one rank cannot write stops every rank."""

    def __init__(self, state, out, oc, point_probes, bodies, integrator, save_checkpoint, resumed=None):
        self.state, self.out, self.oc = state, out, oc
        self.point_probes, self.bodies, self.integrator = point_probes, bodies, integrator
        self.save_checkpoint = save_checkpoint  # f(path, output_state)
        self.par = state.par
        self.root = self.par is None or self.par.rank == 0
        resumed = resumed or {}
        self.entries = [tuple(e) for e in resumed.get("entries", [])]
        self.count = resumed.get("count", 0)
        self.iter_max = resumed.get("iter_max", 0)
        self.grids = [GridSampler(state, g, f"grids[{k}]") for k, g in enumerate(state.case["grids"])]
        # per grid: its frames [(t, part, file)] and their count
        self.grid_series = {g.name: [tuple(e) for e in resumed.get("grid_series", {}).get(g.name, [])]
                            for g in self.grids}
        self.last_good = "(none written)"
        cols = ["time", "step", "dt", "n_fluid", "kinetic_energy", "potential_energy"]
        if oc["surge_front"]:
            cols.append("surge_front")
        cols += point_probes.columns() + body_columns(bodies, state.dim)
        _columns_once(state.case, cols)
        self.stats = integrator.columns()  # per-step figures of the scheme (midpoint, RK45)
        cols += self.stats + (["midpoint_iterations_max"] if "midpoint_iterations" in self.stats else [])
        self.probes = self.steps_log = None

        def start():
            out.mkdir(parents=True, exist_ok=True)
            # frames of an earlier run in the same directory (or, on a restart, written after
            # the checkpoint) would sit beside the series without being listed in it
            keep = {_frame(e[2]) for e in self.entries} | {_frame(e[2]) for v in self.grid_series.values() for e in v}
            for old in [*out.glob("fluid_[0-9]*.vtu"), *out.glob("fluid_[0-9]*.pvtu"), *out.glob("walls_[0-9]*.vtu"),
                        *out.glob("surface_[0-9]*.vtu"), *out.glob("grid_*_[0-9]*.vti"),
                        *out.glob("fluid_failed*.vtu"), *out.glob("fluid_failed.pvtu"), *out.glob(".*.tmp[0-9]*")]:
                if _frame(old.name) not in keep or old.name.startswith("."):
                    old.unlink()
            upto = state.steps if resumed else None  # a restart keeps the rows up to its checkpoint
            self.probes = probes.ProbeWriter(out / "probes.csv", cols, keep_steps=upto)
            self.steps_log = probes.ProbeWriter(out / "steps.csv", ["step", "time", "dt"] + self.stats,
                                                keep_steps=upto) if self.stats else None
            if oc["vtk"] and state.walls.n and not bodies.moving:
                self._write_walls("walls.vtu")

        self._root(start)

    def _agreed(self, fn, here=True):
        """``fn()`` where ``here``; an OSError it raises is raised on every rank."""
        err = None
        if here:
            try:
                fn()
            except OSError as e:
                err = e
        if self.par is not None:
            self.par.agree(err)
        elif err is not None:
            raise err

    def _root(self, fn):
        """``fn()`` on rank 0 (the only process of a plain run); its OSError raised on every rank."""
        self._agreed(fn, self.root)

    def _write_walls(self, name):
        state = self.state
        names = [k for k in ("n", "elementSize", "psi", "v") if k in state.walls.arrays]
        vtk.write_points(self.out / name, state.host(state.walls, "x")[0], dict(zip(names, state.host(state.walls, *names))))

    def _write_fluid(self, base):
        """The fluid's frame ``base``: one .vtu, or a rank's piece each and their .pvtu."""
        state, par = self.state, self.par
        x, v, rho, p, m, ids = state.owned_host("x", "v", "rho", "p", "m", "id")
        fields = {"rho": rho, "p": p, "v": v, "m": m, "id": ids}
        if "kind" in state.fluid.arrays:
            fields["kind"] = state.owned_host("kind")[0]
        if par is None:
            vtk.write_points(self.out / f"{base}.vtu", x, fields)
            return f"{base}.vtu"
        piece = f"{base}_p{par.rank}.vtu"
        self._agreed(lambda: vtk.write_points(self.out / piece, x, fields), here=x.shape[1] > 0)
        counts = par.comm.gather(x.shape[1], root=0)
        self._root(lambda: vtk.write_pvtu(self.out / f"{base}.pvtu", [f"{base}_p{r}.vtu" for r, c in enumerate(counts)
                                                                      if c], fields))
        return f"{base}.pvtu"

    def _write_surface(self, name):
        """The free surface of this frame (``io.surface``), in ``surface.pvd``; in a decomposed
        run rank 0 gathers the particles (the surface crosses the ranks' cuts)."""
        state, par = self.state, self.par
        x, rho, m = state.owned_host("x", "rho", "m")
        vol = m.astype(float) / rho.astype(float)
        x = x.astype(float)
        if par is not None:
            xs, vs = par.comm.gather(x, root=0), par.comm.gather(vol, root=0)
            if self.root:
                x, vol = np.concatenate(xs, axis=1), np.concatenate(vs)
        self.entries.append((state.t, 2, name))

        def write():
            spacing = self.oc["surface_spacing"] or 0.5 * state.dp
            surface.write_surface(self.out / name, *surface.surface_mesh(x, vol, state.h, state.case["model"]["kernel"],
                                                                          spacing))
            vtk.write_pvd(self.out / "surface.pvd", [e for e in self.entries if e[1] == 2])

        self._root(write)

    def write_grid(self, k):
        """A frame of grid k (``[[grids]]``): ``grid_NAME_NNNN.vti`` and ``grid_NAME.pvd``."""
        g = self.grids[k]
        fields = g.fields()  # on every rank (the ranks' nodes are summed)
        series = self.grid_series[g.name]
        name = f"grid_{g.name}_{len(series):04d}.vti"
        series.append((self.state.t, 0, name))

        def write():
            g.write(self.out / name, fields)
            vtk.write_pvd(self.out / f"grid_{g.name}.pvd", series)

        self._root(write)

    def write(self, failed=False, sample=True):
        """A VTK frame (when ``vtk`` is on), the free surface (when ``surface`` is) and, with
        ``sample``, a row of probes.csv."""
        state = self.state
        if sample and not failed:
            self.sample()  # refreshes p from the current density first
        else:
            state.settle()
        if self.oc["vtk"]:
            name = self._write_fluid("fluid_failed" if failed else f"fluid_{self.count:04d}")
            if not failed:
                self.entries.append((state.t, 0, name))

                def series():
                    if state.walls.n and self.bodies.moving:  # a frame of the walls too
                        wname = f"walls_{self.count:04d}.vtu"
                        self._write_walls(wname)
                        self.entries.append((state.t, 1, wname))
                    elif state.walls.n:
                        self.entries.append((state.t, 1, "walls.vtu"))
                    vtk.write_pvd(self.out / "fluid.pvd", [e for e in self.entries if e[1] == 0])
                    vtk.write_pvd(self.out / "case.pvd", [e for e in self.entries if e[1] in (0, 1)])

                self._root(series)
                if not self.root and state.walls.n:  # the same list on every rank (checkpoints)
                    self.entries.append((state.t, 1, f"walls_{self.count:04d}.vtu" if self.bodies.moving
                                         else "walls.vtu"))
                self.last_good = f"{self.out / name} (t = {state.t:.6g} s)"
        if self.oc.get("surface") and not failed:
            self._write_surface(f"surface_{self.count:04d}.vtu")
        if not failed:
            self.count += 1

    def sample(self):
        """One row of probes.csv: time, energies, surge front, the probes, the scheme's figures."""
        state, par = self.state, self.par
        values = self.point_probes.sample()  # refreshes p from the current density first
        x, v, m = state.owned_host("x", "v", "m")
        ek, ep = probes.energies(x, v, m, state.gravity)
        front = probes.surge_front(x, state.dp) if x.shape[1] else -np.inf
        if par is not None:
            ek, ep = (float(e) for e in par.sum([ek, ep]))
            front = float(par.max([front])[0])
        row = {"time": state.t, "step": state.steps, "dt": float(state.P.dt) if state.steps else 0.0,
               "n_fluid": state.n_fluid(), "kinetic_energy": ek, "potential_energy": ep}
        if self.oc["surge_front"]:
            row["surge_front"] = front if np.isfinite(front) else float("nan")
        row.update(values)
        row.update(body_loads(state, self.bodies))
        stats = self.integrator.stats
        row.update(stats)
        if "midpoint_iterations" in stats:
            row["midpoint_iterations_max"] = self.iter_max
            self.iter_max = 0
        self._root(lambda: self.probes.write(row))

    def log_step(self):
        """One row of ``steps.csv`` per step for schemes with per-step figures (midpoint
        iterations and residual, RK45 error and rejections)."""
        if not self.stats:
            return
        state = self.state
        stats = self.integrator.stats
        self.iter_max = max(self.iter_max, stats.get("midpoint_iterations", 0))
        self._root(lambda: self.steps_log.write(dict(stats, step=state.steps, time=state.t, dt=float(state.P.dt))))

    def checkpoint(self, next_out, next_probe, next_grids=()):
        """``checkpoint.npz``: the state, and where the output series stands."""
        self._agreed(lambda: self.save_checkpoint(self.out / "checkpoint.npz", {
            "entries": self.entries, "count": self.count, "iter_max": self.iter_max, "next_out": next_out,
            "next_probe": next_probe, "grid_series": self.grid_series, "next_grids": list(next_grids)}))

    def close(self, summary):
        def finish():
            self.probes.close()
            if self.steps_log is not None:
                self.steps_log.close()
            vtk.write_text(self.out / "run.json", json.dumps(summary, indent=2) + "\n")

        self._root(finish)


def _frame(name):
    """The frame a file belongs to: ``fluid_0003`` of fluid_0003.vtu, .pvtu and its pieces."""
    return re.sub(r"(_p[0-9]+)?\.p?vtu$", "", name)


def _columns_once(case, cols):
    """A case error naming the probe (or else the body) whose column of probes.csv another
    column already has: a reader would take one for the other."""
    seen = set()
    for c in cols:
        if c in seen:
            who = [f"probes[{k}].name" for k, p in enumerate(case["probes"])
                   if c in (p["name"], f"{p['name']}_volume_flux", f"{p['name']}_mass_flux")]
            raise CaseError(f"{case['_source']}: {who[0] if who else 'name'}: the column {c!r} of probes.csv "
                            "would be written twice (a run's own column, another probe's or a body's); "
                            "give it another name")
        seen.add(c)
