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

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from analytic.params import ParameterError, Params, check_k  # noqa: E402

EXIT_USAGE = 2


def add_param_arguments(parser: argparse.ArgumentParser, defaults: Params | None = None) -> None:
    """Add ``--f --gamma --beta --Delta --H --bc --alpha-pc --alpha-ld`` to ``parser``."""
    d = defaults or Params()
    g = parser.add_argument_group("physical parameters (dimensionless, DESIGN.md section 2)")
    g.add_argument("--f", type=float, default=d.f, help="friction coefficient f >= 0 (%(default)s)")
    g.add_argument("--gamma", type=float, default=d.gamma,
                   help="gamma = mu/(c_s sigma0 d_v f) > 0 (%(default)s)")
    g.add_argument("--beta", type=float, default=d.beta,
                   help="beta = c_s/c_d in (0, 1/sqrt 2) (%(default)s)")
    g.add_argument("--Delta", type=float, default=d.Delta,
                   help="Delta = d_v f_ss / d_v f (%(default)s)")
    g.add_argument("--H", type=float, default=d.H, help="strip height H > 0 (%(default)s)")
    g.add_argument("--bc", choices=("velocity", "stress"), default=d.bc,
                   help="top condition (%(default)s)")
    g.add_argument("--alpha-pc", type=float, default=d.alpha_pc,
                   help="Prakash-Clifton alpha_PC >= 0 (%(default)s)")
    g.add_argument("--alpha-ld", type=float, default=d.alpha_ld,
                   help="Linker-Dieterich alpha_LD >= 0 (%(default)s)")


def params_from_args(args: argparse.Namespace) -> Params:
    """Build (and validate) :class:`Params` from parsed arguments."""
    return Params(f=args.f, gamma=args.gamma, beta=args.beta, Delta=args.Delta, H=args.H,
                  bc=args.bc, alpha_pc=args.alpha_pc, alpha_ld=args.alpha_ld)


def parse_k(spec: str, name: str = "--k") -> np.ndarray:
    """Parse ``start:stop:count`` (inclusive, linear) or ``k1,k2,...``.

    Raises:
        ParameterError: On malformed input or a non-positive / non-finite value.
    """
    s = spec.strip()
    try:
        if ":" in s:
            parts = s.split(":")
            if len(parts) != 3:
                raise ValueError
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
            if count < 1:
                raise ParameterError(f"{name} = {spec!r}: count must be >= 1")
            if count > 1 and not stop > start:
                raise ParameterError(f"{name} = {spec!r}: stop must be larger than start")
            values = np.linspace(start, stop, count)
        else:
            values = np.array([float(v) for v in s.split(",") if v.strip()])
    except ValueError:
        raise ParameterError(
            f"{name} = {spec!r} is neither 'start:stop:count' nor a comma list of numbers"
        ) from None
    return check_k(values, name=name.lstrip("-"))


def positive_int(name: str, value: int, minimum: int = 1, maximum: int | None = None) -> int:
    """Check an integer option; raise :class:`ParameterError` naming it otherwise."""
    if value < minimum or (maximum is not None and value > maximum):
        rng = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
        raise ParameterError(f"{name} = {value} is outside its allowed range {rng}")
    return value


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
