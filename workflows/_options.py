"""Command-line rules of the scenes: :func:`make_parser`, PETSc options, :func:`start`.

argparse without prefix abbreviations (``--be`` is an error, not ``--beta``); a usage error is
one line (exit 2); ``--help`` (rank 0 only) lists the scene's PETSc/SLEPc options prefixes.
Single-dash arguments are PETSc/SLEPc options: they are accepted only if they belong to an
object of the scene (``-<prefix><family>...`` with a family of :data:`PETSC_FAMILIES`, e.g.
``-strip_pep_ncv 40``) or are one of :data:`PETSC_GLOBAL` (``-log_view``, ``-help``, ...), and
are inserted into the PETSc options database; anything else (``-beta 0.8``, ``-k 3``) is a
one-line error naming it (exit 2). A value that starts with ``-`` after one of the scene's
options (``--Delta -1e6``, ``--target -0.3-6j``) is that option's value.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from _provenance import set_argv
from _sharing import quiet_jit, rank

from analytic.cli import OneLineParser
from analytic.params import ParameterError

__all__ = ["PETSC_FAMILIES", "PETSC_GLOBAL", "check_petsc_options", "insert_petsc_options",
           "make_parser", "split_petsc", "start"]

#: Option families of SLEPc/PETSc objects (after the object's prefix): ``-<prefix><family>...``.
PETSC_FAMILIES = ("pep_", "nep_", "eps_", "svd_", "mfn_", "st_", "ksp_", "pc_", "rg_", "ds_",
                  "bv_", "fn_", "mat_")
#: Options accepted whatever the prefixes (read by PETSc itself, not by one object).
PETSC_GLOBAL = ("log_view", "help", "options_left", "options_view", "malloc_debug",
                "malloc_dump", "on_error_abort", "mat_mumps_")


class _HelpOnce(argparse.Action):
    """``-h/--help`` printed by rank 0 only (every rank exits 0)."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str | None = None) -> None:  # noqa: A002
        super().__init__(option_strings=option_strings, dest=dest, default=default, nargs=0,
                         help=help)

    def __call__(self, parser, namespace, values, option_string=None) -> None:  # noqa: ANN001
        if rank() == 0:
            parser.print_help()
        parser.exit()


def make_parser(doc: str | None, prefixes: Sequence[str] = (), *, petsc: bool = True,
                formatter_class: type = argparse.ArgumentDefaultsHelpFormatter,
                **kwargs: Any) -> OneLineParser:
    """The scene's argument parser.

    Args:
        doc: The module docstring (its first line is the description).
        prefixes: Options prefixes of every PETSc/SLEPc object the scene creates (``""``: the
            default prefix, i.e. plain ``-pep_type``).
        petsc: ``False`` for scenes without any PETSc object (every single-dash option is then
            an error).
        formatter_class: argparse formatter.
        **kwargs: Passed to :class:`argparse.ArgumentParser`.

    Returns:
        A parser without prefix abbreviations whose usage errors are one line (exit 2), whose
        ``--help`` is printed once and lists the PETSc/SLEPc options prefixes.
    """
    prefixes = tuple(prefixes) if petsc else ()
    if petsc and prefixes:
        shown = ", ".join(f"-{p}pep_..., -{p}st_..." if p else "-pep_..., -st_..." for p in
                          prefixes)
        epilog = ("PETSc/SLEPc options (single dash) of this scene's solvers, options prefixes "
                  f"{', '.join(repr(p) for p in prefixes)}: e.g. {shown} (families "
                  f"{', '.join(f.rstrip('_') for f in PETSC_FAMILIES)}); also "
                  f"{', '.join('-' + g.rstrip('_') for g in PETSC_GLOBAL)}. Any other "
                  "single-dash option is an error.")
    elif petsc:
        epilog = (f"PETSc options: {', '.join('-' + g.rstrip('_') for g in PETSC_GLOBAL)}; any "
                  "other single-dash option is an error.")
    else:
        epilog = "This scene uses no PETSc/SLEPc object: single-dash options are errors."
    kwargs.setdefault("epilog", epilog)
    description = (doc or "").strip().split("\n")[0]
    parser = OneLineParser(description=description, formatter_class=formatter_class,
                           allow_abbrev=False, add_help=False, **kwargs)
    parser.add_argument("-h", "--help", action=_HelpOnce, help="show this help and exit")
    parser.petsc_prefixes = prefixes  # type: ignore[attr-defined]
    parser.petsc_enabled = petsc  # type: ignore[attr-defined]
    return parser


def _looks_like_option(token: str) -> bool:
    """``-x...`` or ``--x...`` (a negative number such as ``-0.5`` or ``-1e3j`` is a value)."""
    if not token.startswith("-") or token in ("-", "--"):
        return False
    try:
        complex(token.replace("i", "j"))
        return False
    except ValueError:
        return True


def split_petsc(parser: argparse.ArgumentParser, argv: Sequence[str]
                ) -> tuple[list[str], list[str]]:
    """Split ``argv`` into the parser's part and the single-dash (PETSc) part.

    A value that follows one of the parser's options (``--target -0.3-6j``) stays with it; a
    single-dash option takes the next token as its value unless that looks like an option.
    """
    actions = parser._option_string_actions  # noqa: SLF001 - argparse has no public map
    mine: list[str] = []
    petsc: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        if tok == "--":
            mine.extend(argv[i:])
            break
        if tok.startswith("--") or tok in actions:
            mine.append(tok)
            act = actions.get(tok.split("=", 1)[0])
            if act is not None and "=" not in tok and act.nargs != 0 and i + 1 < len(argv):
                value = argv[i + 1]
                if value.startswith("-"):  # argparse would take "-0.3-6j" for an option
                    mine[-1] = f"{tok}={value}"
                else:
                    mine.append(value)
                i += 1
        elif _looks_like_option(tok):
            petsc.append(tok)
            if i + 1 < len(argv) and not _looks_like_option(argv[i + 1]):
                petsc.append(argv[i + 1])
                i += 1
        else:
            mine.append(tok)
        i += 1
    return mine, petsc


def check_petsc_options(parser: argparse.ArgumentParser, petsc: Sequence[str]) -> None:
    """Raise :class:`ParameterError` on the first single-dash option no scene object reads."""
    prefixes = getattr(parser, "petsc_prefixes", ())
    enabled = getattr(parser, "petsc_enabled", True)
    for tok in petsc:
        if not _looks_like_option(tok):
            continue
        name = tok.lstrip("-").split("=", 1)[0]
        ok = enabled and (name.startswith(PETSC_GLOBAL) or any(
            name.startswith(p + fam) for p in prefixes for fam in PETSC_FAMILIES))
        if ok:
            continue
        hint = ""
        if "--" + name in parser._option_string_actions:  # noqa: SLF001
            hint = f" (did you mean --{name}?)"
        if not enabled:
            where = "this workflow uses no PETSc/SLEPc object"
        elif prefixes:
            where = ("PETSc/SLEPc options here start with "
                     + ", ".join(f"-{p}<{'|'.join(f.rstrip('_') for f in PETSC_FAMILIES[:6])}>_"
                                 for p in prefixes))
        else:
            where = "no PETSc/SLEPc object of this workflow reads options"
        raise ParameterError(f"unrecognized option {tok}{hint}: {where}; see --help")


def insert_petsc_options(petsc: Sequence[str]) -> None:
    """Put ``petsc`` (``-name [value]`` tokens) into the PETSc options database.

    Objects read the database when they are set up (``setFromOptions``), so options inserted
    after ``PetscInitialize`` apply. ``-log_view`` also starts PETSc's logging (it prints at
    ``PetscFinalize``).
    """
    if not petsc:
        return
    from petsc4py import PETSc

    opts = PETSc.Options()
    i = 0
    while i < len(petsc):
        name = petsc[i].lstrip("-")
        value = None
        if "=" in name:
            name, value = name.split("=", 1)
        elif i + 1 < len(petsc) and not _looks_like_option(petsc[i + 1]):
            value = petsc[i + 1]
            i += 1
        opts.setValue(name, value if value is not None else "")
        if name.startswith("log_view"):
            PETSc.Log.begin()
        i += 1


def start(parser: argparse.ArgumentParser, argv: Sequence[str] | None = None,
          comm: Any = None) -> tuple[argparse.Namespace, Any]:
    """Parse the command line, check and insert the PETSc options, silence the JIT.

    Args:
        parser: From :func:`make_parser`.
        argv: Arguments (default ``sys.argv[1:]``).
        comm: Communicator (default ``MPI.COMM_WORLD``).

    Returns:
        ``(args, comm)``.

    Raises:
        ParameterError: A usage error or a single-dash option no object of the scene reads
            (every rank alike: the command line is the same on every rank).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    set_argv(argv)
    mine, petsc = split_petsc(parser, argv)
    args = parser.parse_args(mine)
    check_petsc_options(parser, petsc)
    if getattr(parser, "petsc_enabled", True):
        insert_petsc_options(petsc)
    quiet_jit()
    if comm is None:
        from mpi4py import MPI

        comm = MPI.COMM_WORLD
    return args, comm
