"""The ``wcsph`` command."""
import argparse
import json
import os
import sys
from pathlib import Path

from .case.config import load, parse_override, read_toml, resolve, shipped_cases
from .errors import CaseError


EXAMPLES = """examples:
  wcsph cases                                  list the shipped cases
  wcsph show dam_break_2d > my_case.toml       start a case of your own from a shipped one
  wcsph run dam_break_2d                       run it; results in runs/dam_break_2d/
  wcsph run my_case.toml -o runs/mine --dp 0.005 --end-time 0.5
  wcsph run dam_break_2d_bi --set model.ViscousTerm=\"PhysicalViscosity_MVT\" --set time.cfl=0.2
  wcsph run dam_break_3d --backend cuda        on an NVIDIA GPU (pip install -e ".[cuda]")
  mpiexec -n 4 wcsph run dam_break_3d          on 4 MPI ranks (pip install -e ".[mpi]"; docs/scaling.md)
  wcsph plot runs/dam_break_2d_bi              PNG plots of the probes (energies, sensors, gauges)

Ctrl-C (or SIGTERM) stops a run after the current step and writes its state; exit codes:
0 done, 2 bad input, 3 the run blew up, 4 output could not be written, 130 interrupted. A stopped or finished run continues
with: wcsph resume runs/dam_break_2d --end-time 2"""


def _parser():
    from .version import __version__

    p = argparse.ArgumentParser(prog="wcsph", description="Weakly compressible SPH solver for free-surface "
                                "flows (classic WCSPH and WCSPH-BI), on the CPU or an NVIDIA GPU.",
                                epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"wcsph {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    r = sub.add_parser("run", help="run a case (a TOML file or a shipped case name)",
                       description="Run a case: a TOML file or the name of a shipped case (wcsph cases).",
                       epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("case", help="a case file (.toml) or a shipped case name")
    r.add_argument("--output", "-o", default=None, help="output directory (default: runs/NAME)")
    r.add_argument("--end-time", type=float, default=None, help="override time.end")
    r.add_argument("--dp", type=float, default=None, help="override the particle spacing dp")
    r.add_argument("--backend", choices=["cpu", "cuda"], default=None)
    r.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                   help="override a case value by its dotted key, e.g. model.xsph_epsilon=0.05")
    r.add_argument("--no-progress", action="store_true", help="plain log lines instead of a progress bar")
    rs = sub.add_parser("resume", help="continue a run from the checkpoint in its output directory",
                        description="Continue a run from DIR/checkpoint.npz (written at the end of a run, at "
                                    "a clean stop and every output.checkpoint_interval), bit for bit as if it "
                                    "had not stopped; output continues in DIR.")
    rs.add_argument("directory", help="the run's output directory (or a checkpoint .npz file)")
    rs.add_argument("--end-time", type=float, default=None, help="run to this time (default: the case's)")
    rs.add_argument("--output", "-o", default=None, help="output directory (default: DIR)")
    rs.add_argument("--no-progress", action="store_true")
    pl = sub.add_parser("plot", help="PNG plots of a run's probes.csv (energies, surge front, sensors, gauges)")
    pl.add_argument("directory", help="the run's output directory")
    sub.add_parser("cases", help="list the shipped cases")
    sub.add_parser("slots", help="list the plug-in slots of [model] and the integrators of [time], their choices and parameters (Markdown)")
    va = sub.add_parser("validate", help="run the validation set against its references; write a report",
                        description="Run each validation case (Poiseuille, Couette, Taylor-Green, hydrostatic "
                                    "tanks, a coarse SPHERIC 2; with the full set also the dam breaks against "
                                    "Martin & Moyce and Koshizuka & Oka, convergence studies, SPHERIC 2 in both "
                                    "models, SPHERIC 6, Lobovsky et al. 2014, the floating box, the sinking cylinder (Moyo & Greenhow 2000) "
                                    "in both models, the oscillating cylinder, the wave flume and the CIEM "
                                    "flume's record), compare it with its reference "
                                    "and tolerance, and write DIR/report.md with a pass/fail table and a plot "
                                    "per check. Exit status 1 when a check fails (the report names the open "
                                    "goals: checks whose tolerance is a target not met yet).")
    va.add_argument("--quick", action="store_true", help="the quick subset (a few minutes on two cores)")
    va.add_argument("--only", default=None, metavar="NAME", help="only the checks whose name contains NAME (the one named NAME, where one is)")
    va.add_argument("--output", "-o", default="runs/validation", help="report directory (default: runs/validation)")
    su = sub.add_parser("surface", help="the free surface of every frame of a finished run, as a mesh "
                                         "(surface_NNNN.vtu, surface.pvd)")
    su.add_argument("directory", help="a run's output directory (with fluid.pvd and run.json)")
    su.add_argument("--spacing", type=float, default=None,
                    help="node spacing of the color function (default: dp/2)")
    sh = sub.add_parser("show", help="print a shipped case as TOML (to start a case of your own)")
    sh.add_argument("case", help="a shipped case name or a case file")
    return p


def _plot(directory):
    from .io.plots import plot_run

    d = Path(directory)
    if not (d / "probes.csv").exists():
        print(f"wcsph: error: {d}: no probes.csv there (is it a run's output directory?)", file=sys.stderr)
        return 2
    kinds = None
    try:
        run = json.loads((d / "run.json").read_text()) if (d / "run.json").exists() else {}
        case = load(run["case"]) if run.get("case") else None
        kinds = {p["name"]: p["kind"] for p in case["probes"]} if case else None
    except (CaseError, KeyError, ValueError, OSError):
        kinds = None
    try:
        for path in plot_run(d, kinds):
            print(path)
    except (ValueError, OSError) as e:
        print(f"wcsph: error: {e}", file=sys.stderr)
        return 2
    return 0


def _check_output(out, what):
    """Refuse, before any set-up, an output directory that cannot be written."""
    p = Path(out)
    if p.exists() and not p.is_dir():
        raise CaseError(f"{what}: {out} is a file, not a directory")
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise CaseError(f"{what}: cannot create {out}: {e.strerror}") from None
    if not os.access(p, os.W_OK | os.X_OK):
        raise CaseError(f"{what}: {out} is not writable")


def _blame(message, args):
    """A value given on the command line is blamed on the command line, not on the file."""
    given = {}
    for text in getattr(args, "sets", []):
        if "=" in text:
            given[text.split("=", 1)[0].strip()] = f"--set {text.split('=', 1)[0].strip()}"
    for key, opt in (("dp", "--dp"), ("time.end", "--end-time"), ("backend", "--backend")):
        if getattr(args, key.split(".")[-1].replace("end", "end_time"), None) is not None:
            given[key] = opt
    head, sep, rest = message.partition(": ")
    key = rest.split(": ", 1)[0] if sep else ""
    if key in given and head != given[key]:
        return f"{given[key]}: {rest.split(': ', 1)[1]}" if ": " in rest else message
    return message


def main(argv=None):
    try:
        return _main(argv)
    except BrokenPipeError:  # e.g. ``wcsph cases | head -1``: the reader has gone
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return 0


def _main(argv):
    args = _parser().parse_args(argv)
    if args.command == "cases":
        for name in shipped_cases():
            desc = read_toml(resolve(name)).get("description", "")
            print(f"{name:20s} {desc}")
        return 0
    if args.command == "slots":
        from .physics.integrators import integrator_table
        from .physics.slots import slot_table

        print(slot_table())
        print()
        print(integrator_table())
        return 0
    if args.command == "plot":
        return _plot(args.directory)
    if args.command == "surface":
        from .io.surface import from_run

        try:
            n = from_run(args.directory, args.spacing)
        except ValueError as e:
            print(f"wcsph: error: {e}", file=sys.stderr)
            return 2
        except OSError as e:
            print(f"wcsph: output error: cannot write to {args.directory}: {e.strerror or e}", file=sys.stderr)
            return 4
        print(f"{n} surfaces written: open {Path(args.directory) / 'surface.pvd'} in ParaView")
        return 0
    if args.command == "validate":
        from .validation import run_all

        from .validation import CHECKS

        names = [fn.__name__ for fn, _ in CHECKS]
        if args.only and not any(args.only in n for n in names):
            print(f"wcsph: error: --only {args.only}: no check's name contains it; checks: {', '.join(names)}",
                  file=sys.stderr)
            return 2
        try:
            _check_output(args.output, "--output")
        except CaseError as e:
            print(f"wcsph: error: {e}", file=sys.stderr)
            return 2
        results = run_all(args.output, quick=args.quick, only=args.only)
        print(f"{sum(r.passed for r in results)} of {len(results)} checks pass; report: "
              f"{Path(args.output) / 'report.md'}")
        return 0 if all(r.passed for r in results) else 1
    if args.command == "show":
        try:
            print(resolve(args.case).read_text(), end="")
        except CaseError as e:
            print(f"wcsph: error: {e}", file=sys.stderr)
            return 2
        return 0
    from .solver import parallel

    try:
        comm = parallel.world()
    except parallel.ParallelError as e:
        print(f"wcsph: error: {e}", file=sys.stderr)
        return 2
    if comm is None:
        return _run(args, print)
    # several processes (mpiexec, srun): rank 0 speaks; each rank takes its share of the
    # node's cores unless NUMBA_NUM_THREADS says otherwise; an unexpected error on one rank
    # ends all of them (the others would wait for it at the next exchange for ever)
    if "NUMBA_NUM_THREADS" not in os.environ:
        import numba

        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
        numba.set_num_threads(max(1, min(numba.config.NUMBA_NUM_THREADS, cores // parallel.local_size(comm))))
    say = print if comm.Get_rank() == 0 else (lambda *a, **k: None)
    try:
        return _run(args, say)
    except BaseException as e:  # noqa: B902 (a crash or a second Ctrl-C: stop the whole job)
        import traceback

        if not isinstance(e, KeyboardInterrupt):
            traceback.print_exc()
        print(f"wcsph: rank {comm.Get_rank()} of {comm.Get_size()} stopped ({type(e).__name__}); ending the job",
              file=sys.stderr, flush=True)
        comm.Abort(1 if not isinstance(e, KeyboardInterrupt) else 130)


def _run(args, print):
    """``wcsph run`` and ``wcsph resume``; ``print`` is silent on the ranks other than 0."""
    from .errors import OutputError, RunInterrupted, SimulationError
    from .solver.simulation import Simulation

    out = None
    try:
        if args.command == "resume":
            meta, arrays = Simulation.read_checkpoint(args.directory)
            case = dict(meta["case"], _source=str(args.directory))
            case["time"] = dict(case["time"], max_steps=0)  # a resumed run goes to its end time
            if args.end_time is not None:
                case["time"]["end"] = args.end_time
            if case["time"]["end"] * (1 - 1e-9) <= meta["t"]:  # the time loop's own slack
                raise CaseError(f"{args.directory}: the run already reached t = {meta['t']:.6g} s; "
                                "give a later --end-time")
            base = Path(args.directory)
            out = args.output or str(base if base.is_dir() else base.parent)
            sim = Simulation(case)
            sim.restore(meta, arrays, source=str(args.directory))
            print(f"resuming {case['name']} at t = {sim.t:.6g} s (step {sim.steps})", flush=True)
        else:
            overrides = [parse_override(s) for s in args.sets]
            if args.end_time is not None:
                overrides.append(("time.end", args.end_time))
            if args.dp is not None:
                overrides.append(("dp", args.dp))
            if args.backend is not None:
                overrides.append(("backend", args.backend))
            case = load(args.case, overrides)
            out = args.output or f"runs/{case['name']}"
            _check_output(out, "--output" if args.output else f"the default output directory {out}")
            sim = Simulation(case)
        ranks = f" on {sim.par.size} MPI ranks (slabs along {'xyz'[sim.par.axis]})" if sim.par is not None else ""
        print(f"{case['name']}: {case['dim']}D, dp = {case['dp']:g} m, {sim.n_fluid()} fluid and "
              f"{sim.walls.n} wall particles, c0 = {sim.c0:.3g} m/s, {case['precision']} on "
              f"{sim.backend.name}{ranks}"
              + (f", its checks read every {sim.check.every} steps" if sim.check.every > 1 else "")
              + f"; output in {out}", flush=True)
        for w in sim.warnings:
            print(f"wcsph: warning: {w}", file=sys.stderr, flush=True)
        summary = sim.run(output=out, progress=not args.no_progress and case["output"]["progress"])
    except CaseError as e:
        print(f"wcsph: error: {_blame(str(e), args)}", file=sys.stderr)
        return 2
    except SimulationError as e:
        print(f"wcsph: run stopped: {e}", file=sys.stderr)
        return 3
    except OutputError as e:
        print(f"wcsph: output error: {e}", file=sys.stderr)
        return 4
    except RunInterrupted as e:
        print(f"wcsph: interrupted: {e}; run.json in {out} says \"interrupted\"", file=sys.stderr)
        return 130
    print(f"done: {summary['steps']} steps to t = {summary['end_time']:.4g} s in "
          f"{summary['wall_time_s']:.1f} s (compile/load {summary['compile_time_s']:.1f} s, "
          f"output {summary['io_time_s']:.1f} s); "
          f"{summary['particle_steps_per_s'] / 1e6:.2f} M particle-steps/s")
    paraview = f"open {out}/case.pvd in ParaView; " if case["output"]["vtk"] else ""
    print(f"results in {out}/: {paraview}time series in {out}/probes.csv; continue with: wcsph resume {out} "
          "--end-time T")
    if summary["dropped"]:
        print(f"note: {summary['dropped']} particles left the domain and were removed")
    print(json.dumps({k: summary[k] for k in ("n_fluid", "n_boundary", "steps")}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
