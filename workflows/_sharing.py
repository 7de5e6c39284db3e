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

__all__ = ["claim_shared", "map_shared", "my_share", "plan_line", "quiet_jit", "rank", "say",
           "say_plan", "share_by_cost", "world_size"]


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
    import numpy as np

    from mpi4py import MPI

    win = MPI.Win.Allocate(8 if comm.rank == 0 else 0, 8, comm=comm)
    if comm.rank == 0:
        np.frombuffer(win.tomemory(), dtype=np.int64)[0] = 0
    comm.Barrier()  # the counter is 0 before anyone reads it
    one, got = np.ones(1, dtype=np.int64), np.zeros(1, dtype=np.int64)
    while True:
        win.Lock(0, MPI.LOCK_SHARED)
        win.Fetch_and_op(one, got, 0, 0, MPI.SUM)
        win.Unlock(0)
        if got[0] >= n:
            break
        yield int(got[0])
    win.Free()  # collective: every rank ends here once the counter passed n
