"""``wcsph plot RUN_DIR``: PNG plots of a run's probes.csv time series (energies, surge front,
pressure sensors, level gauges, flow sections, body loads, the integrator's figures), written
beside it with matplotlib."""
import csv
import math
from pathlib import Path

from .vtk import atomic

#: column groups, each one figure; what a run lacks is skipped
GROUPS = {
    "energies": ("energy [J]", lambda c: c in ("kinetic_energy", "potential_energy")),
    "surge_front": ("surge front x [m]", lambda c: c == "surge_front"),
    "integrator": ("scheme figures", lambda c: c.startswith(("midpoint_", "rk_"))),
    "volume_flux": ("volume flux [m^3/s; m^2/s in 2D]", lambda c: c.endswith("_volume_flux")),
    "mass_flux": ("mass flux [kg/s; kg/(m s) in 2D]", lambda c: c.endswith("_mass_flux")),
    "loads": ("body force [N] and torque [N m]", lambda c: c.endswith(("_fx", "_fy", "_fz", "_torque", "_tx", "_ty",
                                                                       "_tz"))),
}
BASE = {"time", "step", "dt", "n_fluid"}


def plot_run(run_dir, probe_kinds=None):
    """Write one PNG per group of columns into ``run_dir``; return their paths. ``probe_kinds``
    maps probe column names to 'pressure' or 'level' (from the case; else guessed from names)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run_dir = Path(run_dir)
    with open(run_dir / "probes.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{run_dir / 'probes.csv'} has no rows yet")
    cols = list(rows[0])
    t = [float(r["time"]) for r in rows]
    used = set(BASE)
    groups = {}
    for name, (label, pick) in GROUPS.items():
        picked = [c for c in cols if pick(c)]
        used.update(picked)
        if picked:
            groups[name] = (label, picked)
    rest = [c for c in cols if c not in used]
    kinds = probe_kinds or {}
    pressure = [c for c in rest if kinds.get(c, "level" if "level" in c else "pressure") == "pressure"]
    level = [c for c in rest if c not in pressure]
    if pressure:
        groups["pressure"] = ("pressure [Pa]", pressure)
    if level:
        groups["levels"] = ("water level [m]", level)
    written = []
    for name, (label, columns) in groups.items():
        fig, ax = plt.subplots(figsize=(8, 4.5), dpi=120)
        for c in columns:
            y = [float(r[c]) if r[c] not in ("", "nan") else math.nan for r in rows]
            ax.plot(t, y, label=c, lw=1.2)
        ax.set_xlabel("time [s]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small")
        ax.set_title(f"{run_dir.name}: {name}")
        fig.tight_layout()
        path = run_dir / f"plot_{name}.png"
        with atomic(path) as tmp:
            fig.savefig(tmp, format="png")
        plt.close(fig)
        written.append(path)
    return written
