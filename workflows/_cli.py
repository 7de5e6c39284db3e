"""The workflows' shared chores (not physics): command line, PETSc options, output folder, messages.

Every workflow ``workflows/<scene>.py`` follows the same pattern::

    import _cli                      # first of the project's imports (puts the root on sys.path)

    PETSC_PREFIXES = ("strip_", "xs_")   # options prefixes of every SLEPc object the scene uses

    def build_parser():
        p = _cli.make_parser(__doc__, PETSC_PREFIXES)   # no abbreviations, one-line errors
        ...
        return p

    def main(comm=None, argv=None) -> int:
        args, comm = _cli.start(build_parser(), argv, comm)  # parse, PETSc options, JIT quiet
        params = validate(args)                              # ParameterError -> exit 2
        with _cli.RunFolder(comm, args.out, "scene", {"params": ...},
                            resume=args.resume, outputs=("*.csv", "*.png")) as run:
            ...  # compute; write into run.file("x.csv"); PNGs via _cli.png_metadata(...)
        return 0

    if __name__ == "__main__":
        _cli.run(main)

The pieces:

- :func:`make_parser` / :func:`start`: argparse without prefix abbreviations (``--be`` is an
  error, not ``--beta``); a usage error is one line (exit 2); ``--help`` (rank 0 only) lists the
  scene's PETSc/SLEPc options prefixes. Single-dash arguments are PETSc/SLEPc options: they are
  accepted only if they belong to an object of the scene (``-<prefix><family>...`` with a family
  of :data:`PETSC_FAMILIES`, e.g. ``-strip_pep_ncv 40``, ``-xs_st_pc_factor_mat_solver_type
  mumps``) or are one of :data:`PETSC_GLOBAL` (``-log_view``, ``-help``, ...), and are inserted
  into the PETSc options database; anything else (``-beta 0.8``, ``-k 3``) is a one-line error
  naming it (exit 2). Because options are inserted into the database (not given to
  ``PetscInitialize``), workflows import dolfinx/petsc4py at the top like any module.
- :class:`RunFolder`: the output folder, checked collectively before any computation (rank 0
  decides, every rank raises the same :class:`ParameterError`): an existing file, a folder that
  cannot be created or written, a folder holding another run's files (a different scene or
  other parameters, or files the scene does not write) without ``--resume``, a ``--resume``
  whose parameters differ from the folder's record (the message names the first differing
  parameter), and a folder locked by a running run. Writes ``run.json`` (scene, parameters,
  command, versions, ranks, start time) and holds ``run.lock`` (pid, host, time, command) until
  the run ends; a lock left by a dead process on the same host is taken over.
- :func:`versions`, :func:`command`, :func:`png_metadata`, :func:`add_png_metadata`: provenance
  for JSON files and PNG text chunks (``Description``: command, ``Comment``: parameters,
  ``Software``: versions).
- :func:`share_by_cost` / :func:`my_share`: items over ranks, longest first (greedy LPT).
- :func:`run`: the ``__main__`` wrapper: a :class:`ParameterError` is one line on rank 0 and
  exit 2; Ctrl-C, a rank killed under ``mpirun`` (the others get SIGTERM) or an exception on one
  rank says what happened and whether ``--resume`` continues, and never leaves ranks waiting.
- :func:`quiet_jit`: no FFCx/UFL INFO lines.

Also re-exported from :mod:`analytic.cli`: :func:`add_param_arguments`,
:func:`params_from_args`, :func:`parse_k`, :func:`positive_int`.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import fnmatch
import json
import logging
import math
import os
import platform
import shlex
import signal
import socket
import subprocess
import sys
import time
import traceback
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

# The parameter plumbing lives in analytic.cli (shared with `python -m analytic`); re-exported.
from analytic.cli import (  # noqa: E402, F401
    OneLineParser,
    add_param_arguments,
    params_from_args,
    parse_k,
    positive_int,
)
from analytic.params import ParameterError, Params, check_k  # noqa: E402, F401

EXIT_USAGE = 2
#: Option families of SLEPc/PETSc objects (after the object's prefix): ``-<prefix><family>...``.
PETSC_FAMILIES = ("pep_", "nep_", "eps_", "svd_", "mfn_", "st_", "ksp_", "pc_", "rg_", "ds_",
                  "bv_", "fn_", "mat_")
#: Options accepted whatever the prefixes (read by PETSc itself, not by one object).
PETSC_GLOBAL = ("log_view", "help", "options_left", "options_view", "malloc_debug",
                "malloc_dump", "on_error_abort", "mat_mumps_")
RECORD = "run.json"
LOCK = "run.lock"

_STATE: dict[str, Any] = {"argv": None, "folder": None, "comm": None}


# ------------------------------------------------------------------------------- ranks, prints
def rank() -> int:
    """This process's rank in MPI_COMM_WORLD (also before/without MPI_Init: from mpirun's env)."""
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and not mpi.Is_finalized():
        return mpi.COMM_WORLD.rank
    for var in ("OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"):
        if var in os.environ:
            return int(os.environ[var])
    return 0


def world_size() -> int:
    """Number of ranks of the job (1 when not under mpirun)."""
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and not mpi.Is_finalized():
        return mpi.COMM_WORLD.size
    for var in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE"):
        if var in os.environ:
            return int(os.environ[var])
    return 1


def say(*parts: object, err: bool = False) -> None:
    """Print on rank 0 only (stdout, or stderr with ``err``), flushed."""
    if rank() == 0:
        print(*parts, file=sys.stderr if err else sys.stdout, flush=True)


def quiet_jit() -> None:
    """Silence the INFO lines of the form compiler (FFCx/UFL/dolfinx JIT) and friends."""
    logging.disable(logging.INFO)


# -------------------------------------------------------------------------- command line
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
    _STATE["argv"] = argv
    mine, petsc = split_petsc(parser, argv)
    args = parser.parse_args(mine)
    check_petsc_options(parser, petsc)
    if getattr(parser, "petsc_enabled", True):
        insert_petsc_options(petsc)
    quiet_jit()
    if comm is None:
        from mpi4py import MPI

        comm = MPI.COMM_WORLD
    _STATE["comm"] = comm
    return args, comm



def parse_grid(spec: str, name: str = "--k", max_count: int = 100000) -> np.ndarray:
    """A sorted grid without duplicates: ``start:stop:countlog`` (geometric) or :func:`parse_k`.

    Raises:
        ParameterError: One line naming ``name`` (malformed, ``start >= stop``, a count outside
            ``2 .. max_count``, a value that is not finite and positive).
    """
    import numpy as np

    if spec.endswith("log") and spec.count(":") == 2:
        a, b, n = spec[:-3].split(":")
        try:
            a, b, n = float(a), float(b), int(n)
        except ValueError:
            raise ParameterError(f"{name} = {spec!r} is not start:stop:countlog") from None
        if not (0 < a < b and math.isfinite(b) and 2 <= n <= max_count):
            raise ParameterError(f"{name} = {spec!r}: need 0 < start < stop, "
                                 f"2 <= count <= {max_count}")
        return np.geomspace(a, b, n)
    return np.unique(parse_k(spec, name=name))

# ------------------------------------------------------------------------------ provenance
_VERSIONS: dict[str, str] = {}


def versions() -> dict[str, str]:
    """Versions of Python, the numerical stack, the project (git) and the machine (cached).

    Read from the installed package metadata, so it imports nothing heavy; PETSc/SLEPc library
    versions are added once petsc4py/slepc4py are initialised.
    """
    if not _VERSIONS:
        from importlib import metadata

        out = {"python": platform.python_version()}
        for dist, key in (("numpy", "numpy"), ("scipy", "scipy"), ("matplotlib", "matplotlib"),
                          ("fenics-dolfinx", "dolfinx"), ("fenics-ffcx", "ffcx"),
                          ("petsc4py", "petsc4py"), ("slepc4py", "slepc4py"),
                          ("mpi4py", "mpi4py"), ("pyvista", "pyvista")):
            with contextlib.suppress(metadata.PackageNotFoundError):
                out[key] = metadata.version(dist)
        try:
            out["git"] = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"],
                                        capture_output=True, text=True,
                                        timeout=10).stdout.strip() or "unknown"
        except (OSError, subprocess.SubprocessError):
            out["git"] = "unknown"
        out["machine"] = f"{platform.platform()}, {os.cpu_count()} cores"
        _VERSIONS.update(out)
    if "petsc4py.PETSc" in sys.modules and "petsc" not in _VERSIONS:
        from petsc4py import PETSc

        _VERSIONS["petsc"] = ".".join(map(str, PETSc.Sys.getVersion()))
    if "slepc4py.SLEPc" in sys.modules and "slepc" not in _VERSIONS:
        from slepc4py import SLEPc

        _VERSIONS["slepc"] = ".".join(map(str, SLEPc.Sys.getVersion()))
    return dict(_VERSIONS)


def command() -> str:
    """The command line of this run (with ``mpirun -n N`` when there are several ranks)."""
    argv = _STATE["argv"] if _STATE["argv"] is not None else sys.argv[1:]
    cmd = shlex.join([sys.executable, sys.argv[0] if sys.argv else "", *argv])
    n = world_size()
    return f"mpirun -n {n} {cmd}" if n > 1 else cmd


def png_metadata(parameters: dict, title: str = "") -> dict[str, str]:
    """PNG text chunks of a workflow's figure: ``fig.savefig(path, metadata=...)``.

    ``Title``; ``Description``: the command line (:func:`command`); ``Comment``: the parameters
    (JSON); ``Software``: ``bimaterial-stability`` and :func:`versions` (JSON).
    """
    return {"Title": title, "Description": command(),
            "Comment": json.dumps(parameters, default=str),
            "Software": "bimaterial-stability " + json.dumps(versions())}


def add_png_metadata(path: str, parameters: dict, title: str = "") -> None:
    """Write :func:`png_metadata` into an existing PNG (e.g. a PyVista screenshot)."""
    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    info = PngInfo()
    for key, value in png_metadata(parameters, title).items():
        info.add_text(key, value)
    with Image.open(path) as im:
        im.load()
        im.save(path, pnginfo=info)


# -------------------------------------------------------------------------- sharing work
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


# -------------------------------------------------------------------------- output folder
def _first_difference(old: Any, new: Any, path: str = "") -> str | None:
    """Dotted path of the first difference of two JSON values, ``None`` if equal."""
    if isinstance(old, dict) and isinstance(new, dict):
        for key in list(new) + [k for k in old if k not in new]:
            sub = f"{path}.{key}" if path else str(key)
            if key not in old or key not in new:
                return sub
            d = _first_difference(old[key], new[key], sub)
            if d is not None:
                return d
        return None
    if json.dumps(old, sort_keys=True) != json.dumps(new, sort_keys=True):
        return path or "(value)"
    return None


def _lookup(d: Any, path: str) -> Any:
    for key in path.split("."):
        if not isinstance(d, dict) or key not in d:
            return "(absent)"
        d = d[key]
    return d


def _short(v: Any) -> str:
    s = json.dumps(v, default=str)
    return s if len(s) <= 60 else s[:57] + "..."


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class RunFolder:
    """The output folder of one run: checked before any computation, locked, with a record.

    Args:
        comm: Communicator of the run (collective construction via :meth:`open`).
        path: The folder (``--out``).
        scene: Workflow name (recorded; a folder of another scene is refused).
        parameters: Everything that determines the numbers (JSON-able); ``--resume`` must match
            it exactly. Not: command, versions, ranks, timings.
        resume: ``--resume`` was given.
        resumable: The scene writes incrementally and has ``--resume`` (messages on
            interruption say that ``--resume`` continues).
        outputs: ``fnmatch`` patterns of the files the scene writes: a folder without a record
            holding only such files (an older run) may be overwritten; any other file is another
            run's and refuses the folder.
        option: Name of the folder's option in messages.

    Use as a context manager (``with RunFolder(...) as run:``) or call :meth:`open` and
    :meth:`close`. :meth:`open` raises the same :class:`ParameterError` on every rank.
    """

    def __init__(self, comm: Any, path: str, scene: str, parameters: dict, *,
                 resume: bool = False, resumable: bool = False, outputs: Iterable[str] = (),
                 option: str = "--out") -> None:
        self.comm = comm
        self.path = path
        self.scene = scene
        self.parameters = json.loads(json.dumps(parameters, default=str))
        self.resume = resume
        self.resumable = resumable or resume
        self.outputs = tuple(outputs)
        self.option = option
        self.resumed = False  #: True if --resume found a matching record (set by open)
        self._lock_path = os.path.join(path, LOCK)
        self._locked = False

    # -- public
    def file(self, *parts: str) -> str:
        """Path of a file inside the folder."""
        return os.path.join(self.path, *parts)

    def open(self) -> RunFolder:
        """Check, lock and record (rank 0 decides; collective). Returns ``self``."""
        verdict = None
        if self.comm.rank == 0:
            try:
                verdict = self._open_rank0()
            except Exception as err:  # noqa: BLE001 - turned into the same verdict on all ranks
                verdict = f"{self.option} = {self.path!r}: {type(err).__name__}: {err}"
            if verdict is not None:
                self._unlock()
        verdict, self.resumed = self.comm.bcast((verdict, self.resumed), root=0)
        if verdict is not None:
            raise ParameterError(verdict)
        _STATE["folder"] = self
        _tell_watcher("folder", self.path, "1" if self.resumable else "0")
        return self

    def close(self) -> None:
        """Release the lock (rank 0). Idempotent."""
        self._unlock()
        if _STATE.get("folder") is self:
            _STATE["folder"] = None

    def __enter__(self) -> RunFolder:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- rank 0
    def _open_rank0(self) -> str | None:
        out, opt = self.path, self.option
        if os.path.exists(out) and not os.path.isdir(out):
            return f"{opt} = {out!r} exists and is not a folder"
        if os.path.isdir(out):
            msg = self._lock()
            if msg:
                return msg
            msg = self._check_content()
            if msg:
                return msg
        else:
            try:
                os.makedirs(out)
            except OSError as err:
                return f"{opt} = {out!r} cannot be created: {err.strerror or err}"
            msg = self._lock()
            if msg:
                return msg
        return self._write_record()

    def _lock(self) -> str | None:
        info = {"pid": os.getpid(), "host": socket.gethostname(),
                "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "command": command()}
        for _ in range(2):
            try:
                fd = os.open(self._lock_path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                try:
                    with open(self._lock_path) as fh:
                        other = json.load(fh)
                except (OSError, ValueError):
                    other = {}
                pid, host = other.get("pid"), other.get("host")
                if (host == info["host"] and isinstance(pid, int) and pid != os.getpid()
                        and not _pid_alive(pid)):
                    with contextlib.suppress(FileNotFoundError):
                        os.remove(self._lock_path)  # stale: its process is gone
                    continue
                return (f"{self.option} = {self.path!r} is in use by another run (pid {pid} on "
                        f"{host} since {other.get('time')}); wait for it, or use another "
                        f"folder (if no such run is alive, delete {self._lock_path})")
            except OSError as err:
                return (f"{self.option} = {self.path!r} is not writable: "
                        f"{err.strerror or err}")
            with os.fdopen(fd, "w") as fh:
                json.dump(info, fh)
            self._locked = True
            atexit.register(self._unlock)
            return None
        return f"{self.option} = {self.path!r}: could not take the lock {self._lock_path}"

    def _unlock(self) -> None:
        if not self._locked:
            return
        self._locked = False
        with contextlib.suppress(OSError, ValueError):
            with open(self._lock_path) as fh:
                if json.load(fh).get("pid") != os.getpid():
                    return
            os.remove(self._lock_path)

    def _check_content(self) -> str | None:
        out, opt = self.path, self.option
        record_path = os.path.join(out, RECORD)
        if os.path.exists(record_path):
            try:
                with open(record_path) as fh:
                    old = json.load(fh)
            except (OSError, ValueError) as err:
                return f"{opt} = {out!r}: unreadable run record {RECORD} ({err})"
            if old.get("scene") != self.scene:
                return (f"{opt} = {out!r} holds a run of {old.get('scene')!r}, not of "
                        f"{self.scene!r}: use another folder")
            diff = _first_difference(old.get("parameters"), self.parameters)
            if diff is None:
                self.resumed = self.resume
                return None
            what = (f"{diff} = {_short(_lookup(old.get('parameters'), diff))} there, "
                    f"{_short(_lookup(self.parameters, diff))} now")
            if self.resume:
                return (f"--resume: {out!r} holds a run with other parameters ({what}); "
                        "give the same parameters or another folder")
            return (f"{opt} = {out!r} holds another run ({what}); use another folder, or "
                    "delete it")
        foreign = sorted(f for f in os.listdir(out) if f != LOCK
                         and not any(fnmatch.fnmatch(f, pat) for pat in self.outputs))
        if foreign:
            return (f"{opt} = {out!r} holds files that are not this workflow's outputs "
                    f"({foreign[0]}{', ...' if len(foreign) > 1 else ''}): use another folder")
        if self.resume and any(True for f in os.listdir(out) if f != LOCK):
            return (f"--resume: {out!r} has no run record ({RECORD}), so its parameters "
                    "cannot be checked; start again without --resume")
        return None

    def _write_record(self) -> str | None:
        path = os.path.join(self.path, RECORD)
        run_info = {"command": command(), "ranks": self.comm.size,
                    "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "versions": versions()}
        record = {"scene": self.scene, "parameters": self.parameters, "runs": [run_info]}
        if self.resumed:
            with contextlib.suppress(OSError, ValueError):
                with open(path) as fh:
                    record["runs"] = json.load(fh).get("runs", [])[-20:] + [run_info]
        try:
            with open(path + ".tmp", "w") as fh:
                json.dump(record, fh, indent=1, default=str)
            os.replace(path + ".tmp", path)
        except OSError as err:
            return f"{self.option} = {self.path!r} is not writable: {err.strerror or err}"
        return None


# ------------------------------------------------------------------------------ entry point
#: The watcher: a tiny process per rank that outlives it. It reads what the rank tells it
#: (its output folder, a signal, "done") and, if the rank ends without "done" (killed, or
#: stopped by mpirun because another rank died), says so in one line (rank 0's watcher only)
#: and removes the rank's lock. A Python signal handler cannot do this: a rank blocked in a
#: PETSc/MPI call holds the GIL until mpirun's SIGKILL.
_WATCHER = r"""
import json, os, sys
rank, parent, launcher = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
err = 2
if launcher:  # mpirun's own stderr: the rank's pipe to mpirun dies with mpirun
    try:
        err = os.open("/proc/%d/fd/2" % launcher, os.O_WRONLY | os.O_APPEND)
    except OSError:
        pass
folder, resumable, why = None, False, None
for line in sys.stdin:
    key, _, rest = line.rstrip("\n").partition("\t")
    if key == "done":
        sys.exit(0)
    if key == "folder":
        folder, _, res = rest.rpartition("\t")
        resumable = res == "1"
    if key == "why":
        why = rest
if folder:
    lock = os.path.join(folder, "run.lock")
    try:
        with open(lock) as fh:
            if json.load(fh).get("pid") == parent:
                os.remove(lock)
    except (OSError, ValueError):
        pass
if rank != 0:
    sys.exit(0)
if why is None:
    why = ("stopped: the run ended without finishing (killed or interrupted; under mpirun"
           " every rank is stopped when one of them fails or is killed)")
if folder and resumable:
    why += ("; the finished part is in " + folder + ": run the same command with --resume"
            " to continue")
elif folder:
    why += "; " + folder + " may hold incomplete files (this workflow writes them at its end)"
os.write(err, ("\n" + why + "\n").encode())
"""
_WATCH: dict[str, Any] = {"proc": None}


def _tell_watcher(*fields: str) -> None:
    proc = _WATCH["proc"]
    if proc is None or proc.stdin is None or proc.stdin.closed:
        return
    with contextlib.suppress(OSError, ValueError):
        proc.stdin.write("\t".join(fields) + "\n")
        proc.stdin.flush()


def _start_watcher() -> None:
    if _WATCH["proc"] is not None:
        return
    try:
        _WATCH["proc"] = subprocess.Popen(
            [sys.executable, "-S", "-E", "-c", _WATCHER, str(rank()), str(os.getpid()),
             str(os.getppid() if world_size() > 1 else 0)],
            stdin=subprocess.PIPE, text=True, start_new_session=True)
    except OSError:
        _WATCH["proc"] = None


def _watcher_done() -> None:
    _tell_watcher("done")
    proc = _WATCH["proc"]
    if proc is not None and proc.stdin is not None:
        with contextlib.suppress(OSError):
            proc.stdin.close()


def _on_terminate(signum: int, frame: object) -> None:
    """SIGTERM/SIGHUP reaching Python: the watcher says it (see :data:`_WATCHER`)."""
    name = signal.Signals(signum).name
    _tell_watcher("why", f"stopped by {name} (under mpirun: every rank is stopped when one of "
                         "them fails or is killed, or the job was interrupted)")
    _close_folder()
    _flush()
    os._exit(128 + signum)


def _on_interrupt(signum: int, frame: object) -> None:
    """Ctrl-C: exit at once (a KeyboardInterrupt raised inside a finaliser would be lost)."""
    _tell_watcher("why", "interrupted (Ctrl-C)")
    _close_folder()
    _flush()
    os._exit(128 + signum)


def run(main: Callable[..., int | None]) -> None:
    """Run ``main()`` (the ``__main__`` block of every workflow) and exit with its code.

    - :class:`ParameterError` (bad input): ``error: <one line>`` on rank 0, exit 2.
    - Ctrl-C: one line (what happened, whether ``--resume`` continues), exit 130.
    - A rank killed, or stopped by ``mpirun`` because another one failed: one line from rank
      0's watcher process (what happened, whether ``--resume`` continues); its lock removed.
    - Any other exception: its traceback, then, with several ranks, ``MPI_Abort`` so that no
      rank is left waiting in a collective.
    """
    _start_watcher()
    for s in (signal.SIGTERM, signal.SIGHUP):
        with contextlib.suppress(ValueError):
            signal.signal(s, _on_terminate)
    # Ctrl-C: not if ignored (a background job). gmsh's import sets SIG_DFL and every
    # gmsh.finalize() restores the handler found at its import (gmsh.oldsig): made ours.
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, _on_interrupt)
        gmsh = sys.modules.get("gmsh")
        if gmsh is not None and getattr(gmsh, "oldsig", None) is not None:
            gmsh.oldsig = _on_interrupt
    try:
        code = main()
    except ParameterError as err:
        _close_folder()
        if rank() == 0:
            print(f"error: {err}", file=sys.stderr, flush=True)
        _watcher_done()
        sys.exit(EXIT_USAGE)
    except KeyboardInterrupt:
        _tell_watcher("why", "interrupted (Ctrl-C)")
        _close_folder()
        _flush()
        os._exit(130)
    except SystemExit:
        _close_folder()
        _watcher_done()
        raise
    except BaseException as err:  # noqa: BLE001 - reported, then every rank is stopped
        _close_folder()
        traceback.print_exc()
        first = (str(err).strip().splitlines() or [""])[0]
        _tell_watcher("why", f"stopped: rank {rank()} failed ({type(err).__name__}: {first})")
        if world_size() > 1:
            from mpi4py import MPI

            _flush()
            MPI.COMM_WORLD.Abort(1)
        _flush()
        os._exit(1)
    _close_folder()
    _watcher_done()
    sys.exit(int(code or 0))


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()


def _close_folder() -> None:
    folder = _STATE.get("folder")
    if folder is not None:
        _tell_watcher("folder", folder.path, "1" if folder.resumable else "0")
        folder.close()
