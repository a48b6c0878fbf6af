"""The ``wcsph`` command."""
import argparse
import json
import sys

from .config import CaseError, load, parse_override, read_toml, resolve, shipped_cases


def _parser():
    p = argparse.ArgumentParser(prog="wcsph", description="Weakly compressible SPH solver.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a case (a TOML file or a shipped case name)")
    r.add_argument("case")
    r.add_argument("--output", "-o", default=None, help="output directory (default: runs/NAME)")
    r.add_argument("--end-time", type=float, default=None, help="override time.end")
    r.add_argument("--dp", type=float, default=None, help="override the particle spacing dp")
    r.add_argument("--backend", choices=["cpu", "cuda"], default=None)
    r.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                   help="override a case value by its dotted key, e.g. model.xsph=0.05")
    r.add_argument("--no-progress", action="store_true")
    sub.add_parser("cases", help="list the shipped cases")
    return p


def main(argv=None):
    args = _parser().parse_args(argv)
    if args.command == "cases":
        for name in shipped_cases():
            desc = read_toml(resolve(name)).get("description", "")
            print(f"{name:20s} {desc}")
        return 0
    from .solver import Simulation, SimulationError

    try:
        overrides = [parse_override(s) for s in args.sets]
        if args.end_time is not None:
            overrides.append(("time.end", args.end_time))
        if args.dp is not None:
            overrides.append(("dp", args.dp))
        if args.backend is not None:
            overrides.append(("backend", args.backend))
        case = load(args.case, overrides)
        out = args.output or f"runs/{case['name']}"
        sim = Simulation(case)
        print(f"{case['name']}: {case['dim']}D, dp = {case['dp']:g} m, {sim.fluid.n} fluid and "
              f"{sim.walls.n} wall particles, c0 = {sim.c0:.3g} m/s, {case['precision']} on "
              f"{sim.backend.name}; output in {out}", flush=True)
        summary = sim.run(output=out, progress=not args.no_progress and case["output"]["progress"])
    except CaseError as e:
        print(f"wcsph: error: {e}", file=sys.stderr)
        return 2
    except SimulationError as e:
        print(f"wcsph: run stopped: {e}", file=sys.stderr)
        return 3
    print(f"done: {summary['steps']} steps to t = {summary['end_time']:.4g} s in "
          f"{summary['wall_time_s']:.1f} s (compile/load {summary['compile_time_s']:.1f} s, "
          f"output {summary['io_time_s']:.1f} s); "
          f"{summary['particle_steps_per_s'] / 1e6:.2f} M particle-steps/s")
    if summary["dropped"]:
        print(f"note: {summary['dropped']} particles left the domain and were removed")
    print(json.dumps({k: summary[k] for k in ("n_fluid", "n_boundary", "steps")}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
