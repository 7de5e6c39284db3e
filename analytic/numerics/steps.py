"""Step-wise algorithms: generators that ask for function values instead of calling a function.

Newton (:func:`analytic.numerics.roots.polish_steps`), the argument principle's adaptive
contour (:func:`analytic.numerics.roots.winding_steps`), the continuation engine
(:func:`analytic.numerics.continuation.march_steps`) and a root family followed in ``k``
(:func:`analytic.numerics.branches.follow_branch_steps`) are written as generators: each
``yield`` is a request (which points, which function), each ``send`` its answer, and the
``return`` value the result. One algorithm then runs two ways:

- :func:`run_steps`: one generator, each request answered at once (the plain functions
  ``polish``, ``winding_numbers``, ``march``, ``follow_branch`` are this, with the calls they
  made before);
- :func:`run_many`: many generators side by side, the requests of all of them answered together
  in one vectorised call per round (the exact root families of a sweep: hundreds of
  continuations whose determinant calls of 5-100 points each cost mostly numpy's per-call
  overhead).

An answer that raises is thrown into the generator at its ``yield``, as the call it replaces
would have raised there.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Hashable, Iterable, Iterator
from typing import Any, TypeVar

T = TypeVar("T")

#: A step-wise algorithm: yields requests, is sent their answers, returns its result.
Steps = Generator[Any, Any, T]


def run_steps(gen: Steps[T], answer: Callable[[Any], Any]) -> T:
    """Run ``gen`` to its end, answering each request with ``answer(request)``.

    Raises:
        Whatever ``gen`` raises (an exception of ``answer`` is thrown into ``gen`` first).
    """
    try:
        req = next(gen)
        while True:
            try:
                ans = answer(req)
            except Exception as err:  # noqa: BLE001 - raised where the call was made
                req = gen.throw(err)
                continue
            req = gen.send(ans)
    except StopIteration as stop:
        return stop.value


def no_requests(req: object) -> object:
    """The ``answer`` of :func:`run_steps` for a generator that must not ask for anything."""
    raise TypeError(f"a step-wise algorithm asked for {req!r} where nothing can answer it")


def run_many(items: Iterable[tuple[Hashable, Steps[T]]],
             answer_all: Callable[[list[Any]], list[Any]], width: int = 64
             ) -> dict[Hashable, T]:
    """Run many generators side by side, their requests answered together, one call a round.

    Args:
        items: ``(key, generator)`` pairs, taken lazily: at most ``width`` run at once, the next
            is taken when one ends (so an iterator that claims work as a rank gets free keeps
            doing so).
        answer_all: The answers to a list of requests, in order (one vectorised evaluation).
        width: Generators run at once.

    Returns:
        ``{key: result}`` of every generator.

    Raises:
        Whatever a generator raises, or ``answer_all``.
    """
    source: Iterator[tuple[Hashable, Steps[T]]] = iter(items)
    active: list[tuple[Hashable, Steps[T], Any]] = []
    done: dict[Hashable, T] = {}
    exhausted = False

    def start(key: Hashable, gen: Steps[T]) -> None:
        try:
            active.append((key, gen, next(gen)))
        except StopIteration as stop:
            done[key] = stop.value

    while True:
        while not exhausted and len(active) < width:
            try:
                key, gen = next(source)
            except StopIteration:
                exhausted = True
                break
            start(key, gen)
        if not active:
            return done
        answers = answer_all([req for _, _, req in active])
        running = []
        for (key, gen, _), ans in zip(active, answers, strict=True):
            try:
                running.append((key, gen, gen.send(ans)))
            except StopIteration as stop:
                done[key] = stop.value
        active = running
