"""Probes: per-output-step scalar records written to ``probes.csv``."""

import numpy as np

from ..errors import CaseError


def energies(x, v, m, gravity):
    """Kinetic 0.5 sum m |v|^2 and potential -sum m g.x (zero at the origin)."""
    ek = 0.5 * float(np.sum(m * np.sum(v.astype(float) ** 2, axis=0)))
    g = np.asarray(gravity, dtype=float)[:, None]
    ep = -float(np.sum(m * np.sum(g * x.astype(float), axis=0)))
    return ek, ep


def surge_front(x, dp):
    """Foremost extent of the fluid along +x: the largest particle x plus half a spacing."""
    return float(np.max(x[0])) + 0.5 * dp if x.shape[1] else float("nan")


class ProbeWriter:
    """A CSV time series, one whole line written and flushed per row. ``keep_steps``:
    continue an existing file (a restart), keeping its whole rows up to that step: a last
    line cut short by a kill or a full disk (no line end, or a field that is not a number)
    and the rows after the checkpoint are dropped, and the kept rows are rewritten
    atomically before the file is appended to."""

    def __init__(self, path, columns, keep_steps=None):
        self.columns = list(columns)
        kept = []
        if keep_steps is not None and path.exists():
            kept = _whole_rows(path.read_text(), self.columns, keep_steps)
        text = "".join(",".join(r) + "\n" for r in [self.columns, *kept])
        from .vtk import write_text

        write_text(path, text)
        self._f = open(path, "a", newline="")

    def write(self, row):
        line = ",".join(f"{row[c]:.9g}" if isinstance(row[c], float) else str(row[c]) for c in self.columns)
        self._f.write(line + "\n")
        self._f.flush()

    def close(self):
        self._f.close()


def _whole_rows(text, columns, keep_steps):
    """The rows of a CSV series ``text`` that are whole (a line end, every field a number)
    and at most ``keep_steps``, as lists of fields; none when the header is not ``columns``."""
    lines = text.split("\n")
    complete = lines[:-1]  # the last piece has no line end: empty, or a row cut short
    if not complete or complete[0].split(",") != columns:
        return []
    step = columns.index("step")
    kept = []
    for line in complete[1:]:
        fields = line.split(",")
        if len(fields) != len(columns):
            continue
        try:
            [float(f) for f in fields]
        except ValueError:
            continue
        if int(float(fields[step])) <= keep_steps:
            kept.append(fields)
    return kept


# ------------------------------------------------------------------ point probes
from ..physics.loads import DRY  # noqa: E402
from .sampling import PointSampler  # noqa: E402

#: a level gauge samples its line every dp / GAUGE_SAMPLES
GAUGE_SAMPLES = 4


class PointProbes:
    """Pressure sensors and water-level gauges of a case (``probes``), any model.

    * pressure: p(x_s) = sum_j p_j W_sj V_j / sum_j W_sj V_j over fluid particles (Shepard),
      0 while the sensor is dry (kernel sum below ``DRY``). With ``extrapolate`` each p_j is
      first carried to the sensor along the pressure gradient of the momentum equation,
      p_j + rho_j (g - Dv/Dt_j) . (x_s - x_j): a sensor on a wall then reads the pressure at
      the wall, not the mean over the one-sided support in front of it (a support reaches
      2h, four spacings, into a flow whose pressure falls away from the wall); in still
      water it is Adami et al.'s (2012) hydrostatic wall pressure;
    * level: the vertical line from ``position`` up by ``length`` is sampled every dp/4; the
      level is the highest height where the kernel sum sum_j W V_j is at least 1/2 (the free
      surface criterion of DualSPHysics' gauges), interpolated between samples; the line's
      base when it is dry. With ``method = "volume"`` the level is the base plus the water's
      volume per unit area above it, sum_j V_j phi(r_j) over the particles above the base,
      phi the 1D (2D) or 2D (3D) Wendland kernel of the case's h in the horizontal distance
      r_j (integral 1): the water column's height whatever the particles' arrangement near the
      surface (in waves the kernel-sum criterion reads low where the surface particles spread);
      it counts everything above the base, so a gauge over a body or under spray reads those too;
    * flow: the volume and mass flux through the plane through ``position`` normal to
      ``normal`` (the whole plane within the domain; m^3/s in 3D, m^2/s per unit width in
      2D), Q = sum_j V_j (v_j . n) phi(d_j) and sum_j m_j (v_j . n) phi(d_j), d_j the
      particle's distance from the plane and phi the 1D Wendland kernel of the case's h
      (integral 1): the fluid's flux density smoothed across the plane over +-2h, stateless
      (a restart, a rank's slab or particles created and removed change nothing), columns
      ``NAME_volume_flux`` and ``NAME_mass_flux``.
    """

    def __init__(self, state):
        case = state.case
        self.state = state
        self.specs = case["probes"]
        pts, self.slices = [], []
        lo, hi = state.domain
        for k, pr in enumerate(self.specs):
            base = np.asarray(pr["position"], dtype=float)
            if np.any(base < lo) or np.any(base >= hi):
                raise CaseError(f"{case['_source']}: probes[{k}].position: {pr['position']} lies outside "
                                f"the domain {np.round(lo, 6).tolist()} .. {np.round(hi, 6).tolist()}")
            if pr["kind"] == "flow" or (pr["kind"] == "level" and pr["method"] == "volume"):
                line = np.zeros((state.dim, 0))
            elif pr["kind"] == "pressure":
                line = base[:, None]
            else:
                # the grid is half open, [lo, hi): the line stops just below the domain's top
                room = (hi[-1] - base[-1]) * (1.0 - 1e-6)
                length = min(pr["length"] or room, room)
                m = max(2, int(np.ceil(length / (state.dp / GAUGE_SAMPLES))) + 1)
                line = np.repeat(base[:, None], m, axis=1)
                line[-1] = base[-1] + np.linspace(0.0, length, m)
            self.slices.append(slice(sum(p.shape[1] for p in pts), sum(p.shape[1] for p in pts) + line.shape[1]))
            pts.append(line)
        self.n = sum(p.shape[1] for p in pts)
        if not self.n:
            return
        allp = np.concatenate(pts, axis=1)
        self.base = allp
        self.heights = allp[-1]
        self.sampler = PointSampler(state, allp)

    def columns(self):
        return [c for p in self.specs for c in
                ([f"{p['name']}_volume_flux", f"{p['name']}_mass_flux"] if p["kind"] == "flow" else [p["name"]])]

    def _flows(self):
        """{column: value} of the flow sections and the volume gauges."""
        state, par = self.state, self.state.par
        flows = [p for p in self.specs if p["kind"] == "flow"]
        gauges = [p for p in self.specs if p["kind"] == "level" and p["method"] == "volume"]
        if not flows and not gauges:
            return {}
        x, m, rho = state.owned_host("x", "m", "rho")
        h = state.h
        sums = []
        for pr in gauges:
            # the particles within the support of the gauge's line and above its base first
            # (a few hundred of the set), then the kernel on those only, in float64
            base = np.asarray(pr["position"], dtype=float)
            r2 = np.zeros(x.shape[1])
            for a in range(state.dim - 1):
                r2 += (x[a] - base[a]) ** 2
            sel = np.flatnonzero((r2 < 4.0 * h * h) & (x[-1] > base[-1]))
            r = np.sqrt(r2[sel]) / h
            if state.dim == 2:
                phi = 5.0 / (8.0 * h) * (1.0 - 0.5 * r) ** 3 * (1.5 * r + 1.0)
            else:
                phi = 7.0 / (4.0 * np.pi * h * h) * (1.0 - 0.5 * r) ** 4 * (2.0 * r + 1.0)
            sums.append(float(np.sum(m[sel].astype(float) / rho[sel].astype(float) * phi)))
        if flows:
            x, v, m, rho = (a.astype(float) for a in state.owned_host("x", "v", "m", "rho"))
        for pr in flows:
            n = np.asarray(pr["normal"], dtype=float)
            n /= np.linalg.norm(n)
            d = n @ (x - np.asarray(pr["position"], dtype=float)[:, None])
            q = np.abs(d) / h
            phi = np.where(q < 2.0, 5.0 / (8.0 * h) * (1.0 - 0.5 * q) ** 3 * (1.5 * q + 1.0), 0.0)
            un = (n @ v) * phi
            sums += [float(np.sum(m / rho * un)), float(np.sum(m * un))]
        if par is not None:
            sums = [float(s) for s in par.sum(sums)]
        out = {}
        for k, pr in enumerate(gauges):
            out[pr["name"]] = float(pr["position"][-1]) + sums[k]
        sums = sums[len(gauges):]
        for k, pr in enumerate(flows):
            out[f"{pr['name']}_volume_flux"], out[f"{pr['name']}_mass_flux"] = sums[2 * k], sums[2 * k + 1]
        return out

    def sample(self):
        """{probe name: value} at the current state (after refreshing the model's p from
        the current density)."""
        state = self.state
        state.settle()
        flows = self._flows()
        if not self.n:
            return flows
        sums = self.sampler.sums()
        sp, sw, sc = sums["p"], sums["w"], sums["c"]
        par = state.par
        if par is not None:  # each point from the rank whose slab holds it (its neighbours are there)
            mine = par.owner(par.column(self.base)) == par.rank
            sp, sw, sc = par.sum(np.stack([sp * mine, sw * mine, sc * mine]))
        out = {}
        for pr, sl in zip(self.specs, self.slices):
            if pr["kind"] == "flow" or (pr["kind"] == "level" and pr["method"] == "volume"):
                continue
            if pr["kind"] == "pressure":
                w = sw[sl][0]
                s = sp[sl][0] + (sc[sl][0] if pr["extrapolate"] else 0.0)
                out[pr["name"]] = float(s / w) if w >= DRY else 0.0
            else:
                out[pr["name"]] = free_surface_level(self.heights[sl], sw[sl])
        out.update(flows)
        return out


def free_surface_level(z, kernel_sum, threshold=0.5):
    """Highest z where ``kernel_sum`` reaches ``threshold``, linearly interpolated to the
    crossing above it; z[0] when the whole line is dry."""
    wet = np.nonzero(kernel_sum >= threshold)[0]
    if wet.size == 0:
        return float(z[0])
    k = wet[-1]
    if k + 1 >= z.size:
        return float(z[k])
    s0, s1 = kernel_sum[k], kernel_sum[k + 1]
    return float(z[k] + (z[k + 1] - z[k]) * (s0 - threshold) / (s0 - s1))
