"""The errors wcsph raises for a user to read: each one line, naming what to change.

Every layer imports them from here, so that no module imports a layer above it to raise one.
"""


class CaseError(ValueError):
    """A case that cannot run, with a message naming the file and key."""


class SimulationError(RuntimeError):
    """The run stopped on a non-physical state (NaN, runaway velocity)."""


class OutputError(RuntimeError):
    """An output file could not be written (disk full, directory gone, permissions)."""


class RunInterrupted(RuntimeError):
    """The run was stopped by Ctrl-C or SIGTERM; its state at the last full step is written."""


class IntegrationError(RuntimeError):
    """The scheme could not make a step (an adaptive step fell below dtMin)."""
