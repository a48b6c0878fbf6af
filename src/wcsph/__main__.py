"""``python -m wcsph``: the ``wcsph`` command (as under ``mpiexec -n 4 python -m wcsph run CASE``)."""
import sys

from .cli import main

sys.exit(main())
