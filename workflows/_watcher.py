"""The watcher: a tiny process per rank that outlives it (started by :mod:`_supervise`).

Run as ``python -S -E _watcher.py RANK PID LAUNCHER_PID``. It reads what the rank tells it on
stdin (``folder<TAB>path<TAB>resumable``, ``why<TAB>text``, ``done``) and, if the rank ends
without ``done`` (killed, or stopped by mpirun because another rank died), removes the rank's
lock and, for rank 0 only, says in one line what happened and what to do. A Python signal
handler cannot do this: a rank blocked in a PETSc/MPI call holds the GIL until mpirun's
SIGKILL. Standard library only (it starts in a few milliseconds).
"""

import json
import os
import sys

RECORD, LOCK, PARTIAL = "run.json", "run.lock", ".partial"


def _holds_outputs(folder: str) -> bool:
    for top, dirs, files in os.walk(folder):
        dirs[:] = [d for d in dirs if PARTIAL not in d]
        if any(PARTIAL not in f and (top != folder or f not in (RECORD, LOCK)) for f in files):
            return True
    return False


def _remove_lock(folder: str, pid: int) -> None:
    lock = os.path.join(folder, LOCK)
    try:
        with open(lock) as fh:
            if json.load(fh).get("pid") == pid:
                os.remove(lock)
    except (OSError, ValueError, AttributeError):
        pass


def main() -> int:
    """Watch the rank; see the module docstring."""
    rank, parent, launcher = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    err = 2
    if launcher:  # mpirun's own stderr: the rank's pipe to mpirun dies with the rank
        try:
            err = os.open(f"/proc/{launcher}/fd/2", os.O_WRONLY | os.O_APPEND)
        except OSError:
            pass
    folder, resumable, why = None, False, None
    for line in sys.stdin:
        key, _, rest = line.rstrip("\n").partition("\t")
        if key == "done":
            return 0
        if key == "folder":
            folder, _, res = rest.rpartition("\t")
            resumable = res == "1"
        if key == "why":
            why = rest
    if folder:
        _remove_lock(folder, parent)
    if rank != 0:
        return 0
    if why is None:
        why = ("stopped: the run ended without finishing (killed or interrupted; under mpirun"
               " every rank is stopped when one of them fails or is killed)")
    if folder and _holds_outputs(folder):
        why += (f"; the finished part is in {folder}: run the same command with --resume to"
                " continue" if resumable else f"; {folder} holds only complete files; run the"
                " same command again")
    elif not folder:
        why += "; nothing was written: run the same command again"
    else:
        try:
            os.remove(os.path.join(folder, RECORD))
        except OSError:
            pass
        why += f"; nothing was written to {folder}: run the same command again"
    os.write(err, ("\n" + why + "\n").encode())
    return 0


if __name__ == "__main__":
    sys.exit(main())
