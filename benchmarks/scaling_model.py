"""The paper model of docs/scaling.md: communication volume against work per step for the
shipped 3D dam break (column 0.3 x 0.4 x 0.6 m in a 1.2 x 0.4 x 0.8 m tank) at 5 M, 50 M and
500 M particles, on slabs (what ``wcsph.solver.parallel`` does) and on cubic blocks (what 1000 ranks
would need). Counting only, no run: every figure follows from the geometry and the settings
printed at the top.

    python benchmarks/scaling_model.py
"""
import math

COLUMN = 0.3 * 0.4 * 0.6  # m^3 of water
TANK = (1.2, 0.4, 0.8)  # m
SPREAD = 1.2  # m of tank the water covers after the collapse (slabs cut along it)
START = 0.3  # m it covers at the start
DEPTH_AFTER = COLUMN / (SPREAD * TANK[1])  # mean water depth once spread (0.15 m)
H_OVER_DP = 2.0  # smoothing_ratio of the shipped case; support 2h, cell h
NEIGHBOURS = 4 / 3 * math.pi * (2 * H_OVER_DP) ** 3  # within the support: 268
GHOST_BYTES = 49 + 24  # every sorted field of a ghost (x v rho m id cell owned + an integrator's x_n v_n)
#: per model: (numbers per ghost per evaluation, evaluations per step, passes per evaluation,
#: messages per neighbour per evaluation): the state x, v, rho (7 in 3D), and for classic the
#: summation density's rho, p, p/rho^2, V between its two passes
MODELS = {"classic (symplectic Euler)": (7 + 4, 1, 2, 2), "WCSPH-BI conservative (symplectic Verlet)": (7, 2, 1, 1)}
HALO_CELLS = 3  # one support (2 cells of h) and one cell for round-off (``parallel.Decomposition.halo``)
#: assumed rates, to turn counts into times (stated in docs/scaling.md)
PAIRS_PER_S = 2.0e10  # pair-term evaluations per second of one modern GPU (H100/H200 class)
LINK = 20e9  # bytes/s a rank moves through host staging and the network (PCIe 4/5, 200 Gb/s IB)
LATENCY = 5e-6  # s per message (IB, host-staged)


def halo_thickness(dp):
    """Ghost layer thickness: 3 cells of h."""
    return HALO_CELLS * H_OVER_DP * dp


def slabs(n, ranks, numbers, evals, passes, per_eval, length):
    dp = (COLUMN / n) ** (1 / 3)
    t = halo_thickness(dp)
    own = n / ranks
    slab = length / ranks
    ghosts = min(2 * t / length * n, n - own) if ranks > 1 else 0.0
    msgs = 2 * (evals * per_eval + 2) if ranks > 1 else 0
    comm_bytes = evals * ghosts * numbers * 4 + ghosts * GHOST_BYTES
    work = evals * passes * (own + ghosts) * NEIGHBOURS
    return dict(dp=dp, t=t, slab=slab, own=own, ghosts=ghosts, bytes=comm_bytes, work=work, msgs=msgs,
                t_comm=comm_bytes / LINK + msgs * LATENCY, t_work=work / PAIRS_PER_S)


def blocks(n, ranks, numbers, evals, passes, per_eval):
    """Cubic blocks over the water once spread (1.2 x 0.4 x 0.15 m): each rank a cube of
    side a = (volume / ranks)^(1/3) with ghosts on its six faces (26 neighbours)."""
    dp = (COLUMN / n) ** (1 / 3)
    t = halo_thickness(dp)
    own = n / ranks
    a = (COLUMN / ranks) ** (1 / 3)
    ghosts = ((a + 2 * t) ** 3 - a ** 3) / dp ** 3
    msgs = 26 * (evals * per_eval + 2)
    comm_bytes = evals * ghosts * numbers * 4 + ghosts * GHOST_BYTES
    work = evals * passes * (own + ghosts) * NEIGHBOURS
    return dict(dp=dp, t=t, slab=a, own=own, ghosts=ghosts, bytes=comm_bytes, work=work, msgs=msgs,
                t_comm=comm_bytes / LINK + msgs * LATENCY, t_work=work / PAIRS_PER_S)


def table(rows, title):
    print(f"\n{title}\n")
    print("| particles | ranks | dp (mm) | slab / block (mm) | own per rank | ghosts per rank | MB sent per step "
          "| work per step (G pairs) | comm / work time |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n, r, d in rows:
        if d["slab"] < 2 * d["t"]:
            print(f"| {n / 1e6:g} M | {r} | {d['dp'] * 1e3:.2f} | {d['slab'] * 1e3:.1f} | {d['own'] / 1e6:.3g} M "
                  f"| thinner than its two halos ({2 * d['t'] * 1e3:.0f} mm): more ghosts than own particles | | | |")
            continue
        print(f"| {n / 1e6:g} M | {r} | {d['dp'] * 1e3:.2f} | {d['slab'] * 1e3:.0f} | {d['own'] / 1e6:.3g} M "
              f"| {d['ghosts'] / 1e6:.3g} M | {d['bytes'] / 1e6:.1f} | {d['work'] / 1e9:.2f} "
              f"| {d['t_comm'] / d['t_work']:.2f} |")


def main():
    print(f"neighbours per particle {NEIGHBOURS:.0f}; assumed {PAIRS_PER_S:.1e} pairs/s per GPU, "
          f"{LINK / 1e9:g} GB/s and {LATENCY * 1e6:g} us per message")
    for name, (numbers, evals, passes, per_eval) in MODELS.items():
        args = (numbers, evals, passes, per_eval)
        rows = [(n, r, slabs(n, r, *args, SPREAD)) for n in (5e6, 50e6, 500e6) for r in (8, 64, 1000)]
        table(rows, f"{name}: slabs along x over the spread water (1.2 m)")
        rows = [(n, r, slabs(n, r, *args, START)) for n in (5e6, 50e6, 500e6) for r in (8, 64)]
        table(rows, f"{name}: slabs at the start (the column, 0.3 m)")
        rows = [(n, r, blocks(n, r, *args)) for n in (5e6, 50e6, 500e6) for r in (64, 1000)]
        table(rows, f"{name}: cubic blocks (26 neighbours)")
        for n in (5e6, 50e6, 500e6):
            dp = (COLUMN / n) ** (1 / 3)
            t = halo_thickness(dp)
            print(f"- {n / 1e6:g} M: slabs stop paying at about {SPREAD / (2 * t):.0f} ranks over the spread water "
                  f"(a slab as thin as its two halos), {START / (2 * t):.0f} at the start")


if __name__ == "__main__":
    main()
