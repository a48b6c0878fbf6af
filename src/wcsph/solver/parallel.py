"""One case on many processes: MPI (mpi4py) domain decomposition into slabs, ghost particles,
halo exchange, migration and load balance.

Launched with ``mpiexec -n N wcsph run CASE`` (or ``srun``), each rank owns one slab of the
domain along one axis (the longest side of the box the particles occupy, by default), cut at
cell boundaries of the global grid, which every rank shares. A rank holds its own particles
and, after them in its arrays but sorted with them into one cell list, **ghost** copies of
the particles of the other ranks within one kernel support of its slab (plus one column of
cells for round-off). No loop and no physics term knows about any of it:

* **every evaluation** (each integrator stage, each midpoint iteration) first refreshes the
  ghosts' state (x, v, rho) from their owners (``update``): ghosts are advanced by the
  integrator's maps like every particle, but only their owners' values count.
* **between passes**, a field a later pass reads of a neighbour is refreshed the same way
  (``Halo``, which the model's ``derivatives`` calls): the summation density and what the
  EOS makes of it on the ghosts; the no-slip velocity and the boundary pressure of the walls
  near another rank's slab (``update_walls``: every rank holds every wall, but its own fluid
  reaches only one support beyond its slab, so a wall's value comes from the rank whose slab
  holds it). The passes run over the ghosts as well, and what they compute there is
  overwritten.
* **once per step**, before the sort (``redistribute``): ghosts are dropped, particles that
  crossed a cut migrate to their new owner, the cuts move when the particle counts are out of
  balance by more than ``parallel.balance_threshold`` (checked every
  ``parallel.balance_interval`` steps), new ghosts are chosen and sent with every field the
  sort carries, and all are sorted together. The sort's permutation then gives each rank the
  positions of the particles it sends and of the ghosts it receives, fixed for the step.
* a **periodic** cut axis needs nothing else: a ghost is sent where it is, and the periodic
  walk finds it as the image it is across the seam, as it does a particle of the rank's own.

Reductions (the time step's |v|max and |a|max, the integrators' residual and error, energies,
probes, body loads) count a rank's own particles only (``owned``) and are summed or maxed over
ranks, so every rank takes the same decisions (step size, iterations, rejections, stops) and
calls the exchanges the same number of times. Walls are held whole by every rank.

Run on one process, nothing here is used: the solver's single-process path is unchanged.
"""
import os
import time

import numpy as np

#: environment variables a process manager sets for the processes it starts: MPICH's and
#: Intel MPI's hydra and Slurm's PMI-2 (PMI_*), Open MPI (OMPI_*), PMIx (srun --mpi=pmix)
_LAUNCHED = ("PMI_RANK", "PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "PMIX_RANK")

class ParallelError(RuntimeError):
    """MPI was asked for and cannot be used (mpi4py missing)."""


def world():
    """MPI's COMM_WORLD when this process was started by ``mpiexec``/``srun`` with more than one
    process, else None (a plain run never imports MPI)."""
    if not any(k in os.environ for k in _LAUNCHED):
        return None
    try:
        from mpi4py import MPI
    except ImportError:
        raise ParallelError('started by mpiexec, but mpi4py is not installed: pip install -e ".[mpi]" '
                            '(or "mpi4py==4.1.2" built against your site\'s MPI)') from None
    comm = MPI.COMM_WORLD
    return comm if comm.Get_size() > 1 else None


def local_size(comm):
    """How many ranks share this node (to split its cores between them)."""
    from mpi4py import MPI

    return comm.Split_type(MPI.COMM_TYPE_SHARED).Get_size()


def select_gpu(comm):
    """One rank per GPU: the node's ranks take its GPUs in turn (before any CUDA context is
    made). Halo data is staged through the host, so no CUDA-aware MPI is needed."""
    from mpi4py import MPI

    me = comm.Split_type(MPI.COMM_TYPE_SHARED).Get_rank()
    try:
        from numba import cuda

        gpus = len(cuda.gpus)
    except Exception:  # no driver or no GPU: the backend says so, in its own words, when it starts
        return None
    if gpus:
        cuda.select_device(me % gpus)
    return me % gpus if gpus else None


class Halo:
    """What a model's ``derivatives`` calls between its passes in a decomposed run: the
    ghosts' ``fluid(names)`` and the walls' ``walls(pset, names)`` from their owners."""

    def __init__(self, par, fluid):
        self.par, self._fluid = par, fluid

    def fluid(self, names):
        self.par.update(self._fluid, names)

    def walls(self, walls, names):
        self.par.update_walls(walls, names)


class Decomposition:
    """Slabs along ``axis`` of ``grid``'s real cells for the ranks of ``comm``, with one
    kernel support of ghosts (``Grid.reach`` cells). ``axis="auto"``: the axis along
    which ``extent`` (the size of the box the particles occupy) is longest: the domain above
    an open tank is room for splashes, not work to share."""

    def __init__(self, comm, grid, backend, axis="auto", balance_threshold=0.1, balance_interval=20,
                 extent=None, balance="count"):
        from mpi4py import MPI

        self.MPI = MPI
        self.comm = comm.Dup()  # its own context: a user's messages on comm never meet the halo's
        self.rank, self.size = self.comm.Get_rank(), self.comm.Get_size()
        self.grid, self.backend = grid, backend
        dim = grid.dim
        real = np.asarray(grid.shape[:dim], dtype=np.int64) - 2 * grid.reach
        if axis == "auto":
            self.axis = int(np.argmax(real if extent is None else np.asarray(extent)[:dim]))
        else:
            self.axis = "xyz".index(axis)
        if self.axis >= dim:
            raise ValueError(f"axis {axis!r} of a {dim}D case")
        self.ncol = int(real[self.axis])
        lo, _ = grid.lengths()
        self.lo = float(lo[self.axis])
        self.width = float(grid.cell[self.axis])
        self.periodic = bool(grid.periodic[self.axis])
        self.halo = grid.reach + 1  # columns: one support, and one for a cell id rounded the other way
        self._walls = (None, None, None)  # (key, send, receive) of the wall sync lists
        self.threshold = float(balance_threshold)
        self.interval = int(balance_interval)
        self.by_time = balance == "time"
        self._busy = 0.0  # seconds outside exchanges and reductions since the last balance check
        self._mark = None  # (clock, communication time) at the end of the last redistribution
        self.reduce_time = 0.0  # seconds in the reductions (the step's checks, probes, residuals)
        self.cuts = np.linspace(0, self.ncol, self.size + 1).round().astype(np.int64)
        self.send, self.recv = [], []  # (rank, index list) for this step
        self.n_owned = 0
        self.calls = 0  # redistributions so far (one per step)
        self.rebalances = 0
        self.migrated = 0  # particles that moved to another rank (crossing a cut, or a cut moving)
        self.exchange_time = 0.0  # seconds in the halo exchanges and redistributions (not the sort)
        self.sent_bytes = 0  # by this rank's halo updates
        self.imbalance = 0.0  # max / mean - 1 of the particles per rank, at the last check

    # ------------------------------------------------------------------ geometry
    def column(self, x):
        """Column of cells along the cut axis of each position (float64, as every rank
        computes it the same)."""
        c = np.floor((np.asarray(x[self.axis], dtype=np.float64) - self.lo) / self.width)
        return c.astype(np.int64)

    def owner(self, col):
        """The rank whose slab holds each column (outside the domain: the nearest slab)."""
        c = np.clip(col, 0, self.ncol - 1)
        return np.clip(np.searchsorted(self.cuts, c, side="right") - 1, 0, self.size - 1)

    def _near(self, col, d):
        """Columns within the halo of rank d's slab (across a periodic seam too)."""
        a, b = int(self.cuts[d]) - self.halo, int(self.cuts[d + 1]) + self.halo
        if self.periodic:
            span = b - a
            if span >= self.ncol:
                return np.ones(col.shape, dtype=bool)
            return np.mod(col - a, self.ncol) < span
        return (col >= a) & (col < b)

    # ------------------------------------------------------------------ reductions
    def sum(self, values):
        return self._allreduce(values, self.MPI.SUM)

    def max(self, values):
        return self._allreduce(values, self.MPI.MAX)

    def _allreduce(self, values, op):
        t0 = time.perf_counter()
        a = np.ascontiguousarray(values, dtype=np.float64)
        out = np.empty_like(a)
        self.comm.Allreduce(a, out, op=op)
        self.reduce_time += time.perf_counter() - t0  # mostly waiting for the slowest rank
        return out

    def any(self, flag):
        t0 = time.perf_counter()
        out = bool(self.comm.allreduce(bool(flag), op=self.MPI.LOR))
        self.reduce_time += time.perf_counter() - t0
        return out

    def agree(self, error):
        """Raise on every rank if ``error`` (an exception or None) is set on any: a file one
        rank could not write stops all of them, not only that one (the others would wait at
        the next exchange for ever)."""
        failed = self.comm.allgather(None if error is None else str(error))
        if error is not None:
            raise error
        bad = [(r, e) for r, e in enumerate(failed) if e is not None]
        if bad:
            raise OSError(f"rank {bad[0][0]}: {bad[0][1]}")

    # ------------------------------------------------------------------ particles
    def balance(self, col, force=False, whole=False):
        """Move the cuts to equal particle counts per rank (at column boundaries) when the
        imbalance max/mean - 1 exceeds the threshold (``force``: always). ``whole``: every
        rank holds every particle (set-up, restart), so the counts are not summed.

        ``balance = "time"``: each column's particles weigh what a particle costs on the rank
        that holds it now (its seconds outside the exchanges since the last check, over its
        particles), and the imbalance is that of those seconds: a rank whose particles are
        dearer (walls, a busier node) gets fewer of them."""
        counts = np.bincount(np.clip(col, 0, self.ncol - 1), minlength=self.ncol).astype(np.float64)
        if not whole:
            counts = self.sum(counts)
        per_rank = np.add.reduceat(counts, np.minimum(self.cuts[:-1], self.ncol - 1)) * (
            self.cuts[1:] > self.cuts[:-1])
        mean = counts.sum() / self.size
        self.imbalance = float(per_rank.max() / mean - 1.0) if mean > 0 else 0.0
        if self.by_time and not whole:
            busy = np.asarray(self.comm.allgather(self._busy))
            self._busy = 0.0
            if busy.sum() > 0:
                cost = np.where(per_rank > 0, busy / np.maximum(per_rank, 1.0), 0.0)
                cost[per_rank == 0] = cost[per_rank > 0].mean() if (per_rank > 0).any() else 1.0
                counts = counts * cost[self.owner(np.arange(self.ncol))]
                self.imbalance = float(busy.max() / busy.mean() - 1.0)
        if not force and self.imbalance <= self.threshold:
            return False
        cum = np.cumsum(counts)
        targets = cum[-1] * np.arange(1, self.size) / self.size
        inner = np.searchsorted(cum, targets, side="left") + 1
        cuts = np.concatenate([[0], np.minimum(inner, self.ncol), [self.ncol]]).astype(np.int64)
        cuts = np.maximum.accumulate(cuts)
        if np.array_equal(cuts, self.cuts):
            return False
        self.cuts = cuts
        self.rebalances += 0 if force else 1  # the balanced start is not a rebalance
        return True

    def split(self, x):
        """Balanced cuts for all the particles at positions ``x`` (which every rank holds: at
        set-up, on a restart), and the mask of this rank's own."""
        col = self.column(x)
        self.balance(col, force=True, whole=True)
        self.calls = 1  # balanced now: the first redistribution need not
        return self.owner(col) == self.rank

    def redistribute(self, fluid):
        """Drop the ghosts, migrate, rebalance (when due), choose and receive new ghosts, sort.
        A set without ``owned`` flags (just made by ``split``) is all this rank's own. Returns
        how many of this rank's own particles left the domain (the sort drops them).

        Nothing is compacted on the host: the arriving particles (immigrants, then ghosts)
        are appended, and the sort drops the old ghosts and the emigrants as it gathers (a
        boolean compaction of every field cost 3 ms a step at 50 k particles a rank)."""
        t0 = time.perf_counter()
        if self._mark is not None:  # the work since the last redistribution, for balance = "time"
            self._busy += (t0 - self._mark[0]) - (self.exchange_time + self.reduce_time - self._mark[1])
        be, grid = self.backend, self.grid
        names = [k for k in fluid.per_particle() if k != "owned"]
        # what a particle that moves or a ghost carries (the scratch fields are only sized):
        # views on the CPU, one copy each on CUDA
        carried = [k for k in fluid.sorted_fields() if k in names]
        h = {k: np.asarray(be.to_host(fluid[k])) for k in carried}
        x = h["x"]
        n_old = x.shape[1]
        own = (np.asarray(be.to_host(fluid["owned"])) != 0) if "owned" in fluid.arrays \
            else np.ones(n_old, dtype=bool)
        col = self.column(x)
        if self.interval > 0 and self.calls % self.interval == 0:
            self.balance(col[own])
        self.calls += 1
        dest = self.owner(col)
        # migration: particles whose column another rank owns now
        go = own & (dest != self.rank)
        stay = own & ~go
        parts = [None] * self.size
        if go.any():
            for d in np.unique(dest[go]):
                sel = np.nonzero(go & (dest == d))[0]
                parts[d] = {k: h[k][..., sel] for k in carried}
            self.migrated += int(np.count_nonzero(go))
        got = [p for p in self.comm.alltoall(parts) if p is not None]
        imm = {k: np.concatenate([p[k] for p in got], axis=-1) for k in carried} if got else None
        n_imm = imm["x"].shape[1] if imm else 0
        # ghosts for the other ranks, from the particles this rank owns now (staying and arrived)
        stay_idx = np.nonzero(stay)[0]
        col_stay = col[stay_idx]
        col_imm = self.column(imm["x"]) if n_imm else np.zeros(0, dtype=np.int64)
        sel, parts = {}, [None] * self.size
        for d in range(self.size):
            if d == self.rank:
                continue
            a = stay_idx[self._near(col_stay, d)]
            b = np.nonzero(self._near(col_imm, d))[0]
            if a.size or b.size:
                sel[d] = np.concatenate([a, n_old + b])  # positions in the appended arrays
                parts[d] = {k: np.concatenate([h[k][..., a]] + ([imm[k][..., b]] if b.size else []), axis=-1)
                            for k in carried}
        got = self.comm.alltoall(parts)
        sources = [(d, p) for d, p in enumerate(got) if p is not None]
        n_ghost = sum(p["x"].shape[1] for _, p in sources)
        total = n_old + n_imm + n_ghost
        if total > n_old:
            for k in names:
                a = fluid[k]
                if k in fluid.scratch:  # written before it is read: only its size matters
                    fluid[k] = be.to_device(np.empty(a.shape[:-1] + (total,), dtype=a.dtype))
                    continue
                extra = ([imm[k]] if n_imm else []) + [p[k] for _, p in sources]
                fluid[k] = be.to_device(np.concatenate([h[k]] + extra, axis=-1))
        flag = np.zeros(total, dtype=np.uint8)
        flag[stay_idx] = 1
        flag[n_old:n_old + n_imm] = 1
        drop = np.zeros(total, dtype=np.uint8)
        drop[:n_old] = ~stay
        fluid["owned"] = be.to_device(flag)
        fluid.n = total
        t_sort = time.perf_counter()
        be.sort(fluid, grid, drop=be.to_device(drop))
        t_sort = time.perf_counter() - t_sort  # the sort a single process does too: not exchange
        n_in = fluid.n
        perm = np.asarray(be.to_host(fluid["_perm"]))[:total]
        inv = np.empty(total, dtype=np.int64)
        inv[perm] = np.arange(total, dtype=np.int64)
        self.send = []
        for d, idx in sel.items():
            pos = inv[idx]
            pos = pos[pos < n_in]  # left the domain: the receiver drops its copy too
            if pos.size:
                self.send.append((d, be.index(pos)))
        self.recv = []
        start = n_old + n_imm
        for d, p in sources:
            m = p["x"].shape[1]
            pos = inv[start:start + m]
            pos = pos[pos < n_in]
            start += m
            if pos.size:
                self.recv.append((d, be.index(pos)))
        mine = flag != 0
        lost = int(np.count_nonzero(inv[mine] >= n_in))
        self.n_owned = int(np.count_nonzero(mine)) - lost
        self.exchange_time += time.perf_counter() - t0 - t_sort
        self._mark = (time.perf_counter(), self.exchange_time + self.reduce_time)
        return lost

    def update(self, fluid, names):
        """Ghosts' ``names`` fields from their owners: one message each way per neighbour."""
        self._exchange(fluid, names, self.send, self.recv)

    def update_walls(self, walls, names):
        """The walls' ``names`` fields near another rank's slab from the rank whose slab holds
        them (a wall pass of this rank sees its own fluid within one support only). Every rank
        holds every wall in the same order (same geometry, same sort), so the lists follow
        from the positions alone, on both sides; they are made again when the walls move (a
        new ``x``), for another set (a body's loads) or after a rebalance."""
        key = (id(walls), id(walls["x"]), walls.n, self.cuts.tobytes())
        if self._walls[0] != key:
            col = self.column(self.backend.to_host(walls["x"]))
            owner = self.owner(col)
            send, recv = [], []
            for d in range(self.size):
                if d != self.rank:
                    out = np.nonzero((owner == self.rank) & self._near(col, d))[0]
                    into = np.nonzero((owner == d) & self._near(col, self.rank))[0]
                    if out.size:
                        send.append((d, self.backend.index(out)))
                    if into.size:
                        recv.append((d, self.backend.index(into)))
            self._walls = (key, send, recv)
        self._exchange(walls, names, self._walls[1], self._walls[2])

    def _exchange(self, pset, names, send, recv):
        """``names`` of ``pset`` at the ``send`` lists to their ranks, into the ``recv`` lists."""
        if not send and not recv:
            return
        t0 = time.perf_counter()
        be = self.backend
        names = [k for k in names if k in pset.arrays]
        arrays = [pset[k] for k in names]
        dtype = np.dtype(arrays[0].dtype)
        rows = [int(np.prod(a.shape[:-1])) for a in arrays]
        width = sum(rows)
        reqs, inbox = [], []
        for d, idx in recv:
            buf = np.empty((width, idx.size), dtype=dtype)
            reqs.append(self.comm.Irecv(buf, source=d, tag=11))
            inbox.append((idx, buf))
        outbox = []
        for d, idx in send:
            buf = np.empty((width, idx.size), dtype=dtype)  # C order: MPI sends the memory as it lies
            row = 0
            for a, r in zip(arrays, rows):
                buf[row:row + r] = np.asarray(be.take(a, idx)).reshape(r, idx.size)
                row += r
            outbox.append(buf)
            self.sent_bytes += buf.nbytes
            reqs.append(self.comm.Isend(buf, dest=d, tag=11))
        self.MPI.Request.Waitall(reqs)
        for idx, buf in inbox:
            row = 0
            for a, r in zip(arrays, rows):
                be.put(a, idx, buf[row:row + r].reshape(a.shape[:-1] + (idx.size,)))
                row += r
        self.exchange_time += time.perf_counter() - t0

    def gather(self, arrays):
        """Every rank's own particles' ``arrays`` (dict of host arrays) concatenated on rank 0
        (None elsewhere), for a checkpoint any number of ranks can restart from."""
        parts = self.comm.gather(arrays, root=0)
        if self.rank != 0:
            return None
        return {k: np.concatenate([p[k] for p in parts], axis=-1) for k in arrays}
