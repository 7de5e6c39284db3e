"""The watcher: a tiny process per rank that outlives it (started by :mod:`_supervise`).

Run as ``python -S -E _watcher.py RANK PID LAUNCHER_PID``. It reads what the rank tells it on
stdin (``folder<TAB>path<TAB>resumable``, ``why<TAB>text``, ``done``) and, if the rank ends
without ``done`` (killed, or stopped by mpirun because another rank died), removes the rank's
lock and, for rank 0 only, says in one line what happened and what to do. A Python signal
handler cannot do this: a rank blocked in a PETSc/MPI call holds the GIL until mpirun's
SIGKILL. Standard library only (it starts in a few milliseconds).

Under mpirun a rank that fails (a full disk, a bug) prints its own line before it aborts the
job; rank 0's watcher would then add a second one (rank 0 stopped by mpirun's SIGTERM). So the
failing rank first tells rank 0's watcher (:func:`say_reported`): a datagram to an abstract Unix
socket named after mpirun's pid (:func:`address`; no file, so a full disk cannot stop it; one
node, like the rest of the watcher), which rank 0's watcher reads when its rank has ended.
"""

import json
import os
import signal
import socket
import sys

RECORD, LOCK, PARTIAL = "run.json", "run.lock", ".partial"
SEEN: list[int] = []  # signals received (under mpirun: see _join_launcher)
REPORTED = b"reported"


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


def address(launcher: int) -> bytes:
    """The abstract socket of rank 0's watcher under the mpirun of pid ``launcher``."""
    return f"\0frictional-watcher-{os.getuid()}-{launcher}".encode()


def say_reported(launcher: int) -> None:
    """Tell rank 0's watcher that this rank printed the run's stop line (best effort)."""
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
            sock.sendto(REPORTED, address(launcher))
    except OSError:  # no watcher listening (not started yet, or not on this node)
        pass


def _listen(launcher: int) -> socket.socket | None:
    try:
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    except OSError:
        return None
    try:
        sock.bind(address(launcher))
        sock.setblocking(False)
    except OSError:
        sock.close()
        return None
    return sock


def _reported(sock: socket.socket | None) -> bool:
    """Another rank has printed the stop line (its datagram is queued before it aborted)."""
    if sock is None:
        return False
    try:
        while True:
            if sock.recv(64) == REPORTED:
                return True
    except OSError:  # nothing (more) queued
        return False


def _note(signum: int, frame: object) -> None:
    SEEN.append(signum)


def _join_launcher(launcher: int) -> None:
    """Move into mpirun's process group, so that a terminal's Ctrl-C reaches this process too.

    mpirun puts every rank in a process group of its own, and on SIGINT it stops them with
    SIGTERM: the ranks cannot tell Ctrl-C from a kill, but the watcher in mpirun's (the
    terminal's foreground) group sees the SIGINT itself. SIGINT/SIGTERM/SIGHUP only noted here.
    """
    for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(s, _note)
    try:
        os.setpgid(0, os.getpgid(launcher))
    except OSError:  # another session (a launcher started with setsid): not seen, said as TERM
        pass


def _launcher_stderr(launcher: int, default: int) -> int:
    """The launcher's (mpirun's) own stderr, the very open file (pidfd_getfd): a shared offset.

    With ``2> file`` a new open of ``/proc/PID/fd/2`` has an offset of its own: output mpirun
    forwards later (a dying rank's last progress bar) was written over the line. The shared
    offset puts it after the line. Falls back to that open where pidfd_getfd is not allowed.
    """
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pidfd = libc.syscall(434, launcher, 0)  # pidfd_open (Linux >= 5.3)
        if pidfd >= 0:
            fd = libc.syscall(438, pidfd, 2, 0)  # pidfd_getfd (Linux >= 5.6, ptrace rights)
            os.close(pidfd)
            if fd >= 0:
                return fd
    except (OSError, AttributeError):
        pass
    try:
        return os.open(f"/proc/{launcher}/fd/2", os.O_WRONLY | os.O_APPEND)
    except OSError:
        return default


def main() -> int:
    """Watch the rank; see the module docstring."""
    rank, parent, launcher = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    err, sock = 2, None
    if launcher:  # mpirun's own stderr: the rank's pipe to mpirun dies with the rank
        _join_launcher(launcher)
        err = _launcher_stderr(launcher, err)
        if rank == 0:
            sock = _listen(launcher)
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
    if signal.SIGINT in SEEN:
        why = "stopped by SIGINT (Ctrl-C; mpirun then stops every rank)"
    if why is None:
        why = ("stopped: the run ended without finishing (killed or interrupted; under mpirun"
               " every rank is stopped when one of them fails or is killed)")
    said = _reported(sock)
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
    if not said:
        os.write(err, ("\n" + why + "\n").encode())
    return 0


if __name__ == "__main__":
    sys.exit(main())
