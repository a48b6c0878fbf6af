"""The solver: a small run state (``state``), set up from a case (``setup``), stepped by an
ordered list of stages (one file each), driven by the time loop (``loop``) with its output
and checkpoints; ``Simulation`` composes them. (Not ``wcsph.run``: that name is the function
that runs a case, and a package of the same name was hidden behind it.)"""
