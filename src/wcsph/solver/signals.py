"""Stage: signals. Ctrl-C (SIGINT) and SIGTERM ask the time loop to stop after the current
step, at a whole step's state, which is then written."""
import signal
import threading


class StopRequest:
    """While active, Ctrl-C (SIGINT) and SIGTERM only ask the time loop to stop after the
    current step, so that the state written is a whole step's; a second Ctrl-C stops at once.
    Outside the main thread (where Python allows no signal handlers) it does nothing."""

    NAMES = {signal.SIGINT: "Ctrl-C (SIGINT)", signal.SIGTERM: "SIGTERM"}

    def __init__(self):
        self.signal = None
        self._previous = {}

    def _handle(self, signum, frame):
        if self.signal is not None and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self.signal = self.NAMES.get(signum, f"signal {signum}")

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for sig in self.NAMES:
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc):
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        return False
