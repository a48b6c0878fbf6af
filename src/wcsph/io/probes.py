"""Probes: per-output-step scalar records written to ``probes.csv``."""
import csv

import numpy as np


def energies(x, v, m, gravity):
    """Kinetic 0.5 sum m |v|^2 and potential -sum m g.x (zero at the origin)."""
    ek = 0.5 * float(np.sum(m * np.sum(v.astype(float) ** 2, axis=0)))
    g = np.asarray(gravity, dtype=float)[:, None]
    ep = -float(np.sum(m * np.sum(g * x.astype(float), axis=0)))
    return ek, ep


def surge_front(x, dp):
    """Foremost extent of the fluid along +x: the largest particle x plus half a spacing."""
    return float(np.max(x[0])) + 0.5 * dp


class ProbeWriter:
    def __init__(self, path, columns):
        self.columns = columns
        self._f = open(path, "w", newline="")
        self._w = csv.writer(self._f)
        self._w.writerow(columns)

    def write(self, row):
        self._w.writerow([f"{row[c]:.9g}" if isinstance(row[c], float) else row[c] for c in self.columns])
        self._f.flush()

    def close(self):
        self._f.close()
