"""The time loop: steps to the end time with the output's callbacks between steps, stops
cleanly on a signal or a non-physical state, and sums the run up (``run.json``). The last
step is the first that reaches the end time (steps are not shortened to land on it), so a
finished run resumed to a later end time (``wcsph resume --end-time``) is bit for bit the
run made straight to it.

Between steps callbacks fall due on simulated time, as TrixiParticles.jl's do: a VTK frame
every ``output.interval`` (with a probes row unless ``probe_interval`` is set), a probes row
every ``output.probe_interval``, a frame of each ``[[grids]]`` table every its ``interval``, a
checkpoint every ``output.checkpoint_interval``.
"""
import time
from pathlib import Path

from ..errors import OutputError, RunInterrupted, SimulationError
from .progress import Progress
from .output import Output
from .signals import StopRequest


class Every:
    """A callback due each ``interval`` of simulated time from ``start`` (never when the
    interval is 0); ``next`` is where it stands (saved in checkpoints)."""

    def __init__(self, interval, start, fn):
        self.interval, self.next, self.fn = interval, start, fn

    def due(self, t, slack):
        return self.interval > 0 and t >= self.next - slack

    def __call__(self):
        self.fn()
        self.next += self.interval


def run(sim, output, end_time, progress):
    """Run ``sim`` (a ``Simulation``) to ``end_time``; the summary dict. A file that cannot be
    written stops the run with an ``OutputError``; every file written before is whole."""
    try:
        return _run(sim, output, end_time, progress)
    except OSError as e:
        ckpt = Path(output) / "checkpoint.npz" if output is not None else None
        last = (f"; the last checkpoint ({ckpt}) is intact" if ckpt is not None and ckpt.exists() else "")
        raise OutputError(f"cannot write to {output}: {e.strerror or e}; the files written before "
                          f"are whole{last}") from None


def _run(sim, output, end_time, progress):
    state, case = sim.state, sim.case
    sim.read_checks()  # steps taken before (and sized on a device) move the time on first
    end = end_time if end_time is not None else case["time"]["end"]
    oc = case["output"]
    writer = None
    resumed = sim.resumed_output or {}
    if output is not None:
        writer = Output(state, Path(output), oc, sim.probes, sim.bodies, sim.integrator, sim.save_checkpoint,
                        sim.resumed_output)
    max_steps = case["time"]["max_steps"]
    par = state.par
    show = (oc["progress"] if progress is None else progress) and (par is None or par.rank == 0)
    probe_every = oc["probe_interval"]  # 0: a probes.csv row with every frame
    frames = Every(oc["interval"] or end / 20, resumed.get("next_out", state.t),
                   lambda: writer.write(sample=not probe_every))
    rows = Every(probe_every, resumed.get("next_probe", state.t), lambda: writer.sample())
    # each [[grids]] table at its own rate (0: with the frames)
    starts = resumed.get("next_grids", [])
    grids = [Every(g["interval"] or frames.interval, starts[k] if k < len(starts) else state.t,
                   lambda k=k: writer.write_grid(k)) for k, g in enumerate(case["grids"])] if writer else []

    def checkpoint():
        writer.checkpoint(frames.next, rows.next, [g.next for g in grids])

    checkpoints = Every(oc["checkpoint_interval"], state.t + oc["checkpoint_interval"], checkpoint)
    slack = 1e-9 * end  # round-off in the summed time; not worth a step of its own
    clock = _Clock()
    status, message = "completed", ""
    stop = StopRequest()
    try:
        with Progress(end, enabled=show) as bar, stop:
            while True:
                callbacks = (frames, rows, *grids, checkpoints) if writer is not None else ()
                # steps the device sized and the host has not read may have brought the time
                # up to state.t + state.lead: read them before anything might fall due
                ahead = state.t + state.lead
                if (stop.signal is not None or ahead >= end - slack or any(c.due(ahead, slack) for c in callbacks)
                        or bool(max_steps and state.steps >= max_steps)):
                    sim.read_checks()  # a device's checks of the steps since the last read, first
                ending = state.t >= end - slack or bool(max_steps and state.steps >= max_steps)
                due = [c for c in callbacks if c.due(state.t, slack)]
                for c in due:
                    if c is checkpoints:
                        c()
                    else:
                        clock.io(c)
                written = frames in due
                stopping = stop.signal is not None
                if par is not None and par.any(stopping):  # every rank stops at the same step
                    stopping = True
                    stop.signal = stop.signal or "a signal to another rank"
                if stopping:
                    sim.read_checks()
                    status = "interrupted"
                    message = f"stopped by {stop.signal} at t = {state.t:.6g} s (step {state.steps})"
                    if writer is not None:
                        if not written:
                            writer.write()
                        message += f"; state written to {writer.last_good}"
                    break
                if ending:
                    break
                # not clipped onto the end time: the run ends at the first step at or past it (as
                # DualSPHysics' does), so a run extended past its end is the run made straight
                dt = sim.time_step()
                t0 = time.perf_counter()
                sim.step(dt)
                if writer is not None:
                    writer.log_step()
                clock.stepped(t0, state.steps)
                bar.update(state.t, state.steps, clock.rate(state.steps))
    except SimulationError as e:
        status, message = "failed", str(e)
        if writer is not None:
            writer.write(failed=True)
            message += f"; last good output: {writer.last_good}"
    if writer is not None and status != "failed":
        checkpoint()  # a clean stop or the end: the run can be continued
    summary = _summary(sim, status, message, clock)
    if writer is not None:
        writer.close(summary)
    if status == "failed":
        raise SimulationError(message)
    if status == "interrupted":
        raise RunInterrupted(message)
    return summary


class _Clock:
    """Wall time of the run, of its output, of its first step (compiling) and of the steps
    after it (the rate)."""

    def __init__(self):
        self.start = time.perf_counter()
        self.io_time = 0.0
        self.compile_time = None
        self.t_loop = None
        self.steps0 = 0
        self.io0 = 0.0

    def io(self, callback):
        t0 = time.perf_counter()
        callback()
        self.io_time += time.perf_counter() - t0

    def stepped(self, t0, steps):
        if self.compile_time is None:
            self.compile_time = time.perf_counter() - t0
            self.t_loop = time.perf_counter()
            self.steps0, self.io0 = steps, self.io_time

    def stepping(self):
        """Seconds stepping after the first step, less the output's."""
        if self.t_loop is None:
            return 0.0
        return time.perf_counter() - self.t_loop - (self.io_time - self.io0)

    def rate(self, steps):
        elapsed = time.perf_counter() - self.t_loop
        return (steps - self.steps0) / max(elapsed - (self.io_time - self.io0), 1e-9)


def _summary(sim, status, message, clock):
    state, case, par = sim.state, sim.case, sim.state.par
    wall = time.perf_counter() - clock.start
    n_fluid = state.n_fluid()
    dropped = state.dropped if par is None else int(par.sum([state.dropped])[0])
    stepping = clock.stepping()
    timed_steps = state.steps - clock.steps0 if clock.t_loop else 0
    summary = {
        "case": case["name"], "status": status, "message": message, "model": case["model"]["name"],
        "backend": state.backend.name, "precision": case["precision"], "dim": state.dim, "dp": state.dp,
        "h": state.h, "kernel": case["model"]["kernel"], "speed_of_sound": state.c0, "particle_mass": state.mass,
        "n_fluid": n_fluid, "n_boundary": state.walls.n, "dropped": dropped,
        "steps": state.steps, "evaluations": state.evaluations, "end_time": state.t, "wall_time_s": wall,
        "compile_time_s": sim.setup_time + (clock.compile_time or 0.0), "io_time_s": clock.io_time,
        "stepping_time_s": stepping,
        "particle_steps_per_s": n_fluid * timed_steps / stepping if stepping > 0 else 0.0,
        "checks_read_every": sim.check.every,  # steps between the host's reads of the checks
    }
    if par is not None:  # the decomposition: ranks, cuts, the exchanges' share of the time
        share = par.sum([par.exchange_time, par.n_owned]) / par.size
        summary["parallel"] = {
            "ranks": par.size, "axis": "xyz"[par.axis], "cuts": [int(c) for c in par.cuts],
            "rebalances": par.rebalances, "imbalance": par.imbalance,
            "migrated": int(par.sum([par.migrated])[0]),
            "exchange_time_s_mean": float(share[0]), "exchange_time_s_max": float(par.max([par.exchange_time])[0]),
            "particles_per_rank_max": int(par.max([par.n_owned])[0]), "particles_per_rank_mean": float(share[1])}
    if sim.open is not None:  # particles created at inlets, removed at outlets
        summary["open_boundary"] = sim.open.summary()
    return summary
