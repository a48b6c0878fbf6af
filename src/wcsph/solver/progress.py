"""Progress display: a rich bar on a terminal, plain lines otherwise."""
import sys
import time


class Progress:
    def __init__(self, end_time, enabled=True, stream=None):
        self.end = end_time
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.tty = enabled and self.stream.isatty()
        self._bar = None
        self._last_line = 0.0
        self._t0 = time.perf_counter()

    def __enter__(self):
        if self.tty:
            from rich.console import Console
            from rich.progress import BarColumn, Progress as Bar, TextColumn, TimeRemainingColumn

            self._bar = Bar(TextColumn("t = {task.fields[t]:.4f} s"), BarColumn(),
                            TextColumn("{task.percentage:>5.1f}%"),
                            TextColumn("{task.fields[rate]:>8.1f} steps/s"), TimeRemainingColumn(),
                            console=Console(file=self.stream), transient=False)
            self._bar.__enter__()
            self._task = self._bar.add_task("run", total=self.end, t=0.0, rate=0.0)
        return self

    def update(self, t, steps, rate):
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.update(self._task, completed=min(t, self.end), t=t, rate=rate)
            return
        now = time.perf_counter()
        if now - self._last_line >= 5.0 or t >= self.end:
            self._last_line = now
            eta = (self.end - t) / t * (now - self._t0) if t > 0 else float("nan")
            print(f"t = {t:.4f} / {self.end:g} s  step {steps}  {rate:.1f} steps/s  ETA {eta:.0f} s",
                  file=self.stream, flush=True)

    def __exit__(self, *exc):
        if self._bar is not None:
            self._bar.__exit__(*exc)
