"""Shared command-line plumbing for the workflow scripts (not physics).

- :func:`add_param_arguments` / :func:`params_from_args`: the physical parameters, once.
- :func:`parse_k`: ``start:stop:count`` or a comma list.
- :func:`run`: calls ``main``; a :class:`~analytic.params.ParameterError` (a user's mistake)
  becomes one line on stderr (rank 0 only) and exit code 2. Every rank validates the same
  input before any collective call, so every rank exits the same way.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# The parameter plumbing lives in analytic.cli (shared with `python -m analytic`); re-exported.
from analytic.cli import (  # noqa: E402, F401
    add_param_arguments,
    params_from_args,
    parse_k,
    positive_int,
)
from analytic.params import ParameterError, Params, check_k  # noqa: E402, F401

EXIT_USAGE = 2


def parse_with_petsc_options(parser: argparse.ArgumentParser,
                              argv: list[str] | None = None
                              ) -> tuple[argparse.Namespace, list[str]]:
    """Parse ``argv``, letting single-dash PETSc/SLEPc options (and their values) through.

    Returns:
        ``(args, petsc_args)``; ``petsc_args`` is meant for ``slepc4py.init``.

    An unknown ``--option`` or a stray leading word is a usage error (argparse's, exit 2).
    """
    args, petsc_args = parser.parse_known_args(argv)
    bad = [a for a in petsc_args if a.startswith("--")]
    if petsc_args and not petsc_args[0].startswith("-"):
        bad.insert(0, petsc_args[0])
    if bad:
        parser.error(f"unrecognized arguments: {' '.join(bad)}")
    return args, petsc_args


def run(main: Callable[[], int | None]) -> None:
    """Run ``main()``; exit 2 with one line on a :class:`ParameterError`, else its return code."""
    try:
        code = main()
    except ParameterError as err:
        rank = 0
        if "mpi4py" in sys.modules:
            from mpi4py import MPI

            rank = MPI.COMM_WORLD.rank
        if rank == 0:
            print(f"error: {err}", file=sys.stderr, flush=True)
        sys.exit(EXIT_USAGE)
    sys.exit(int(code or 0))
