"""Run by ``test_cache.py``: the wall placement map (``motion.make_place``) compiled or
loaded from Numba's cache for each dimension given on the command line, each checked to
place a few points right and to write no row past its set's. Exit status 1 when one does."""
import sys
import numpy as np
import wcsph  # installs the cache guards
from wcsph.backends.cpu import CpuBackend
from wcsph.boundaries.motion import WallPlacement, make_place, POSE

be = CpuBackend()
ok = True
for dim in map(int, sys.argv[1:]):
    run = be.make_map(make_place(dim, True))
    n = 5
    x0 = np.arange(dim * n, dtype=float).reshape(dim, n)
    n0 = np.zeros((dim, n)); n0[0] = 1.0
    body = np.zeros(n, dtype=np.int64)
    pose = np.zeros((1, POSE)); pose[0, 0] = 1.0; pose[0, 4:4 + dim] = 1.0
    R = np.eye(3); pose[0, 7:16] = R.ravel()
    guard = np.full((dim + 1, n), -7.0)  # a row past the set's: must stay untouched
    x = guard[:dim]
    rest = [np.zeros((dim, n)) for _ in range(3)]
    run(WallPlacement(x0, n0, body, pose, x, rest[0], rest[1], rest[2]), None)
    good = np.allclose(x, x0 + 1.0) and np.all(guard[dim] == -7.0)
    print(dim, "ok" if good else "WRONG", flush=True)
    ok = ok and good
sys.exit(0 if ok else 1)
