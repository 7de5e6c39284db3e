"""Ranks, messages and work sharing of the scenes: :func:`say`, :func:`map_shared`, ...

:func:`say_plan` prints a long run's plan line up front.

:func:`rank` and :func:`world_size` are :mod:`analytic.cli`'s (one definition in the project).
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from analytic.cli import rank, world_size

__all__ = ["EndClaims", "claim_shared", "map_shared", "my_share", "plan_line", "quiet_jit",
           "rank", "say", "say_plan", "share_by_cost", "world_size"]


def say(*parts: object, err: bool = False) -> None:
    """Print on rank 0 only (stdout, or stderr with ``err``), flushed."""
    if rank() == 0:
        print(*parts, file=sys.stderr if err else sys.stdout, flush=True)


def plan_line(what: str, seconds: float, ranks: int, note: str = "") -> str:
    """The up-front plan of a long run: ``plan: <what> on R rank(s), about T s[ note]``.

    ``T`` to 0.1 s below 10 s, else to 1 s.
    """
    t = f"{seconds:.1f}" if seconds < 10 else f"{seconds:.0f}"
    return f"plan: {what} on {ranks} rank(s), about {t} s" + (f" {note}" if note else "")


def say_plan(comm: Any, what: str, seconds: float, note: str = "", quiet: bool = False) -> None:
    """Rank 0 prints :func:`plan_line` on stderr (after validation, before the work)."""
    if not quiet and comm.rank == 0:
        print(plan_line(what, seconds, comm.size, note), file=sys.stderr, flush=True)


def quiet_jit() -> None:
    """Silence the INFO lines of the form compiler (FFCx/UFL/dolfinx JIT) and friends."""
    logging.disable(logging.INFO)


def share_by_cost(costs: Sequence[float], size: int) -> list[list[int]]:
    """Indices of ``costs`` split over ``size`` ranks, longest first onto the least loaded rank.

    Greedy LPT (longest processing time first): the largest load is at most 4/3 of the optimum.
    Deterministic (ties by index), so every rank computes the same split. Each rank's indices
    are returned in increasing order.
    """
    if size < 1:
        raise ValueError("size must be >= 1")
    load = [0.0] * size
    share: list[list[int]] = [[] for _ in range(size)]
    for i in sorted(range(len(costs)), key=lambda j: (-float(costs[j]), j)):
        r = min(range(size), key=lambda q: (load[q], q))
        load[r] += float(costs[i])
        share[r].append(i)
    return [sorted(s) for s in share]


def my_share(comm: Any, costs: Sequence[float]) -> list[int]:
    """This rank's indices of :func:`share_by_cost` over ``comm``."""
    return share_by_cost(costs, comm.size)[comm.rank]


def map_shared(comm: Any, costs: Sequence[float], fn: Callable[[int], Any]) -> dict[int, Any]:
    """``{i: fn(i)}`` for every index of ``costs``, each computed on one rank, on every rank.

    This rank computes its :func:`my_share`; the results are gathered on every rank
    (collective: every rank calls it).
    """
    local = {i: fn(i) for i in my_share(comm, costs)}
    merged: dict[int, Any] = {}
    for part in comm.allgather(local):
        merged.update(part)
    return merged


def claim_shared(comm: Any, n: int) -> Iterator[int]:
    """The indices ``0 .. n-1``, each on one rank, claimed in order by whichever rank is free.

    Collective: every rank iterates to the end. For work whose cost no estimate predicts (the
    exact root families: 0.002 to 0.8 s each at the paper's defaults): a rank takes the next
    index when it finishes the last, from a counter on rank 0 read and incremented atomically
    (``MPI_Fetch_and_op`` on a window, passive target: rank 0 need not take part). Order the
    work longest first. One rank: ``range(n)``.
    """
    if comm.size == 1:
        yield from range(n)
        return
    yield from _draws(comm, 1, 0, n)


def _draws(comm: Any, slots: int, slot: int, n: int) -> Iterator[int]:
    """This rank's draws ``0 <= t < n`` from counter ``slot`` of ``slots`` counters on rank 0.

    Each draw reads and increments the counter atomically (``MPI_Fetch_and_op`` on a window,
    passive target: rank 0 need not take part), so the ranks drawing from one counter get
    distinct values. Collective: every rank of ``comm`` creates the window and iterates to the
    end, where it is freed.
    """
    import numpy as np

    from mpi4py import MPI

    win = MPI.Win.Allocate(8 * slots if comm.rank == 0 else 0, 8, comm=comm)
    if comm.rank == 0:
        np.frombuffer(win.tomemory(), dtype=np.int64)[:] = 0
    comm.Barrier()  # the counters are 0 before anyone reads them
    one, got = np.ones(1, dtype=np.int64), np.zeros(1, dtype=np.int64)
    while True:
        win.Lock(0, MPI.LOCK_SHARED)
        win.Fetch_and_op(one, got, 0, slot, MPI.SUM)
        win.Unlock(0)
        if got[0] >= n:
            break
        yield int(got[0])
    win.Free()  # collective: every rank ends here once its counter passed n


def _blocks(costs: Sequence[float], size: int) -> list[tuple[int, int]]:
    """``[lo, hi)`` of consecutive indices per pair of ranks (:class:`EndClaims`), by cost.

    ``ceil(size / 2)`` blocks; a block shared by two ranks gets twice the cost of the last
    block of an odd ``size`` (one rank). Cut where the running sum of ``costs`` first reaches
    each block's share of the total (every rank computes the same cuts).
    """
    n, pairs = len(costs), (size + 1) // 2
    weights = [2.0] * (size // 2) + [1.0] * (size % 2)
    total = float(sum(costs)) or 1.0
    shares = [total * w / sum(weights) for w in weights]
    cuts, run, target, b = [0], 0.0, 0.0, 0
    for i, c in enumerate(costs):
        if b < pairs - 1 and run >= target + shares[b]:
            target += shares[b]
            cuts.append(i)
            b += 1
        run += float(c)
    cuts += [n] * (pairs + 1 - len(cuts))
    return list(zip(cuts[:-1], cuts[1:], strict=True))


class EndClaims:
    """The indices ``0 .. n-1`` in runs of consecutive indices, taken from both ends by free ranks.

    The indices are cut into ``ceil(size / 2)`` blocks of consecutive indices (:func:`_blocks`,
    by ``costs``); ranks ``2 b`` and ``2 b + 1`` share block ``b``: the first walks it upwards
    from its low end, the second downwards from its high end, each taking its next index when
    it is free from the block's counter on rank 0 (``MPI_Fetch_and_op``, passive target, as
    :func:`claim_shared`), until they meet. So each index is taken once, the work balances
    itself like :func:`claim_shared` (no cost estimate needed inside a block), and each rank's
    indices are consecutive: for a sweep in ``k``, each rank's solvers see neighbouring ``k``
    (continuation) and only the meshes of its part of the ``k`` range (:func:`share_by_cost` on
    the estimate dealt neighbouring ``k`` to alternate ranks, and every rank built every mesh).
    Iterate once, on every rank (collective: the window is freed at the end). One rank:
    ``range(n)``.

    Args:
        comm: The communicator.
        n: Number of indices.
        costs: Estimated cost per index (the blocks' cut; default: equal).
        bar: Rank 0 shows a progress bar of its block's indices taken, with this description
            and unit, e.g. ``"k values"`` (``None``: none).

    Attributes:
        block: ``(lo, hi)`` of this rank's block.
        claimed: Indices of the block taken so far by its ranks (as of this rank's last claim).
    """

    def __init__(self, comm: Any, n: int, costs: Sequence[float] | None = None,
                 bar: str | None = None) -> None:
        self.comm, self.desc = comm, bar
        blocks = _blocks(list(costs) if costs is not None else [1.0] * n, comm.size)
        self.block = blocks[comm.rank // 2] if comm.size > 1 else (0, n)
        self.pairs = len(blocks)
        self.claimed = 0

    def __iter__(self) -> Iterator[int]:
        lo, hi = self.block
        bar = None
        if self.desc is not None and self.comm.rank == 0 and hi > lo:
            from tqdm import tqdm

            ranks = f" (ranks 0-1 of {self.comm.size})" if self.comm.size > 2 else ""
            bar = tqdm(total=hi - lo, desc=self.desc + ranks, unit=f" {self.desc}",
                       file=sys.stderr)
        for i in self._taken(lo, hi):
            if bar is not None:
                bar.update(self.claimed - bar.n)
            yield i
        if bar is not None:
            bar.update(bar.total - bar.n)
            bar.close()

    def _taken(self, lo: int, hi: int) -> Iterator[int]:
        """The indices this rank takes (see the class docstring); ``claimed`` kept up."""
        if self.comm.size == 1:
            for i in range(lo, hi):
                self.claimed = i - lo + 1
                yield i
            return
        down = self.comm.rank % 2 == 1
        for own, got in enumerate(_draws(self.comm, self.pairs, self.comm.rank // 2, hi - lo)):
            self.claimed = got + 1
            # the block's ranks have taken got + 1 <= hi - lo indices in all, so this rank's
            # own run never reaches the other's
            yield hi - 1 - own if down else lo + own
        self.claimed = hi - lo
