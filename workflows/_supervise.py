"""How a scene's process ends: :func:`run` (the ``__main__`` wrapper) and its watcher.

Every way a run ends is one line on stderr naming what happened and what to do, with an honest
exit code, and no rank left waiting:

====================================  =========  ============================================
how                                   exit code  line (printed by the process that knows)
====================================  =========  ============================================
normal end                            ``main``'s  (the scene's result line)
bad input (:class:`ParameterError`)   2          ``error: <parameter and allowed range>``
full disk or quota                    1          ``stopped: no space left on device in DIR...``
SIGTERM / SIGHUP (mpirun, a kill)     128 + sig  ``stopped by SIGTERM ...``
Ctrl-C (SIGINT)                       130        ``stopped by SIGINT (Ctrl-C) ...``
an exception (a bug)                  1          traceback, then ``stopped: rank R failed ...``
SIGKILL, or a rank blocked in MPI     (mpirun)   rank 0's watcher (:mod:`_watcher`)
====================================  =========  ============================================

Each ``stopped`` line ends with what to do: ``--resume`` if the run's folder holds finished
results of a resumable scene, else "run the same command again" (a run that wrote nothing
removes its ``run.json``). With several ranks a failing rank calls ``MPI_Abort`` after its line,
having told rank 0's watcher that the line is said (:func:`_watcher.say_reported`: one line,
not a second one for rank 0's SIGTERM).
"""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import subprocess
import sys
import traceback
from collections.abc import Callable
from typing import Any

from _sharing import rank, world_size
from _writing import is_no_space

from analytic.params import ParameterError

__all__ = ["EXIT_FAILED", "EXIT_USAGE", "register_folder", "run", "start_watcher",
           "unregister_folder"]

EXIT_USAGE = 2
EXIT_FAILED = 1
_WATCHER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_watcher.py")
_STATE: dict[str, Any] = {"proc": None, "folder": None}


def register_folder(folder: Any) -> None:
    """The run's :class:`_runfolder.RunFolder` (its lock is released however the run ends)."""
    _STATE["folder"] = folder
    _tell_watcher("folder", folder.path, "1" if folder.resumable else "0")


def unregister_folder(folder: Any) -> None:
    """Forget ``folder`` (closed)."""
    if _STATE["folder"] is folder:
        _STATE["folder"] = None


def _tell_watcher(*fields: str) -> None:
    proc = _STATE["proc"]
    if proc is None or proc.stdin is None or proc.stdin.closed:
        return
    with contextlib.suppress(OSError, ValueError):
        proc.stdin.write("\t".join(fields) + "\n")
        proc.stdin.flush()


def start_watcher() -> None:
    """Start this rank's watcher (idempotent); ``_cli`` does it at import for a scene script."""
    if _STATE["proc"] is not None:
        return
    try:
        _STATE["proc"] = subprocess.Popen(
            [sys.executable, "-S", "-E", _WATCHER, str(rank()), str(os.getpid()),
             str(os.getppid() if world_size() > 1 else 0)],
            stdin=subprocess.PIPE, text=True, start_new_session=world_size() == 1)
    except OSError:
        _STATE["proc"] = None
        return
    # A normal interpreter exit is not a stop: a script that imports _cli and never calls
    # run() (or returns from it) tells its watcher so. Stops leave through os._exit (no atexit).
    atexit.register(_at_exit)


def _at_exit() -> None:
    """Normal interpreter exit: the watcher is done, unless Ctrl-C ended the script."""
    if isinstance(getattr(sys, "last_value", None), KeyboardInterrupt):  # before run()
        _tell_watcher("why", "stopped by SIGINT (Ctrl-C)")
        return
    _watcher_done()


def _watcher_done() -> None:
    _tell_watcher("done")
    proc = _STATE["proc"]
    if proc is not None and proc.stdin is not None:
        with contextlib.suppress(OSError):
            proc.stdin.close()


def what_to_do() -> str:
    """The end of a ``stopped`` line: how to continue, given what the run's folder holds."""
    folder = _STATE["folder"]
    if folder is None:
        return "run the same command again"
    if folder.holds_outputs():
        if folder.resumable:
            return (f"the finished part is in {folder.path}: run the same command with --resume"
                    " to continue")
        return f"{folder.path} holds only complete files; run the same command again"
    return f"nothing was written to {folder.path}: run the same command again"


def _stop(line: str, code: int, *, everyone: bool = False) -> None:
    """Print ``line`` (rank 0, or this rank with ``everyone``), release the folder, exit."""
    if everyone or rank() == 0:
        with contextlib.suppress(Exception):
            print("\n" + line, file=sys.stderr, flush=True)  # after a progress bar's \r
    _watcher_done()
    _close_folder(failed=True)
    _flush()
    if everyone and world_size() > 1:
        from mpi4py import MPI

        if rank() != 0:  # rank 0's watcher would add a second line for rank 0's SIGTERM
            from _watcher import say_reported

            say_reported(os.getppid())

        MPI.COMM_WORLD.Abort(code)
    os._exit(code)


def _on_signal(signum: int, frame: object) -> None:
    """SIGTERM/SIGHUP/SIGINT reaching Python: one line, exit ``128 + signum``.

    Serially the process prints it; under mpirun, which stops forwarding the ranks' output once
    it stops the job, rank 0's watcher writes it to mpirun's own stderr.
    """
    name = signal.Signals(signum).name
    cause = ("Ctrl-C" if signum == signal.SIGINT else "a kill or a closed terminal"
             if world_size() == 1 else
             "under mpirun: another rank failed or was killed, or mpirun was signalled")
    line = f"stopped by {name} ({cause}); {what_to_do()}"
    if world_size() == 1:
        _stop(line, 128 + signum)
    _tell_watcher("why", line.split("; ")[0])
    _close_folder(failed=True)
    _flush()
    os._exit(128 + signum)


def run(main: Callable[..., int | None]) -> None:
    """Run ``main()`` (the ``__main__`` block of every workflow) and exit with its code.

    See the module docstring for each way a run ends.
    """
    start_watcher()
    for s in (signal.SIGTERM, signal.SIGHUP):
        with contextlib.suppress(ValueError):
            signal.signal(s, _on_signal)
    # Ctrl-C: not if ignored (a background job). gmsh's import sets SIG_DFL and every
    # gmsh.finalize() restores the handler found at its import (gmsh.oldsig): made ours.
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, _on_signal)
        gmsh = sys.modules.get("gmsh")
        if gmsh is not None and getattr(gmsh, "oldsig", None) is not None:
            gmsh.oldsig = _on_signal
    try:
        code = main()
    except ParameterError as err:
        _close_folder(failed=True)
        if rank() == 0:
            print(f"error: {err}", file=sys.stderr, flush=True)
        _watcher_done()
        sys.exit(EXIT_USAGE)
    except KeyboardInterrupt:
        _on_signal(signal.SIGINT, None)
    except SystemExit:
        _close_folder()
        _watcher_done()
        raise
    except BaseException as err:  # noqa: BLE001 - reported, then every rank is stopped
        folder = _STATE["folder"]
        if is_no_space(err):
            where = folder.path if folder is not None else os.getcwd()
            how = ("with --resume" if folder is not None and folder.resumable
                   and folder.holds_outputs() else "again")  # nothing finished: no record kept
            _stop(f"stopped: no space left on device in {where}; free space and run the same "
                  f"command {how}", EXIT_FAILED, everyone=True)
        traceback.print_exc()
        first = (str(err).strip().splitlines() or [""])[0]
        _stop(f"stopped: rank {rank()} failed ({type(err).__name__}: {first}); {what_to_do()}",
              EXIT_FAILED, everyone=True)
    _close_folder()
    _watcher_done()
    sys.exit(int(code or 0))


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()


def _close_folder(failed: bool = False) -> None:
    folder = _STATE["folder"]
    if folder is not None:
        folder.close(failed=failed)
