"""The run: a small state (``state``), set up from a case (``setup``), stepped by an ordered
list of stages (one file each), driven by the time loop (``loop``) with its output and
checkpoints; ``Simulation`` composes them."""
