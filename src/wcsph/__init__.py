"""wcsph: weakly compressible SPH for free-surface flows, on CPU (Numba) and NVIDIA GPUs."""
from .backends import numba_cache, threads

import warnings as _warnings

from numba.core.errors import NumbaIRAssumptionWarning as _IRWarning

# Numba's internal pedantic SSA check reports the visitor inlined several times into the
# periodic neighbour walk (a note for Numba's developers; the compiled code is right: the
# periodic cases are checked against their exact solutions)
_warnings.filterwarnings("ignore", category=_IRWarning)
threads.configure()  # before any compiled loop starts Numba's threads
numba_cache.install()  # an index left by an older wcsph is recompiled, not a traceback

from .case.config import load, validate
from .errors import CaseError
from .errors import OutputError, RunInterrupted, SimulationError
from .solver.simulation import Simulation
from .version import __version__

__all__ = ["CaseError", "OutputError", "RunInterrupted", "Simulation", "SimulationError", "load", "validate", "run"]


def run(case, output=None, overrides=(), **kwargs):
    """Run a case (path, shipped name or case dict) and return the summary dict."""
    if isinstance(case, dict):
        cfg = validate(case)
    else:
        cfg = load(case, overrides)
    return Simulation(cfg, backend=kwargs.pop("backend", None)).run(output=output, **kwargs)
