"""The output folder of a run (:class:`RunFolder`): checked, locked and recorded before any work.

Rank 0 decides, every rank raises the same :class:`ParameterError`: an existing file, a folder
that cannot be created or written, a folder holding another run's files (a different scene or
other parameters, or files the scene does not write) without ``--resume``, a ``--resume`` on a
folder that does not exist or whose parameters differ from the folder's record (the message
names the first differing parameter), and a folder locked by a running run.

Writes ``run.json`` (strict JSON) and holds ``run.lock`` until the run ends. The lock is
created whole (a temporary file hard-linked to ``run.lock``): a full disk never leaves an empty
lock. A stale lock is taken over with a note on stderr: its process is gone (same host), or it
is empty or unreadable and older than :data:`LOCK_GRACE` s; another host's lock never is.
Partial files of an interrupted write are deleted on open; a run that fails before writing
anything removes its ``run.json``, so the corrected command is accepted.
"""

from __future__ import annotations

import atexit
import contextlib
import fnmatch
import json
import os
import socket
import time
from collections.abc import Iterable
from typing import Any

import _supervise
from _parts import Parts
from _provenance import command, describe_difference, dumps, versions
from _sharing import say
from _writing import PARTIAL, atomic_open, remove_partials

from analytic.params import ParameterError

__all__ = ["LOCK", "LOCK_GRACE", "RECORD", "RunFolder"]

RECORD = "run.json"
LOCK = "run.lock"
#: Seconds after which an empty or unreadable lock is stale (a lock is written whole, so an
#: empty one is left by a crash of an older version, or by a full disk before it was written).
LOCK_GRACE = 30.0


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _stale_lock(path: str, other: dict, host: str) -> str | None:
    """Why the lock at ``path`` (content ``other``, ``{}`` if unreadable) is stale, else None."""
    pid = other.get("pid")
    if not other:
        try:
            age = time.time() - os.path.getmtime(path)
        except OSError:
            return "gone"
        if age > LOCK_GRACE:
            return f"empty or unreadable, {age:.0f} s old"
        return None
    if other.get("host") == host and isinstance(pid, int) and pid != os.getpid() \
            and not _pid_alive(pid):
        return f"its process {pid} is gone"
    return None


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
        self.parameters = json.loads(dumps(parameters))
        self.resume = resume
        self.resumable = resumable or resume
        self.outputs = tuple(outputs)
        self.option = option
        self.resumed = False  #: True if --resume found a matching record (set by open)
        self._lock_path = os.path.join(path, LOCK)
        self._locked = False
        self._note: str | None = None

    # -- public
    def file(self, *parts: str) -> str:
        """Path of a file inside the folder."""
        return os.path.join(self.path, *parts)

    def parts(self, folder: str, names: str, count: int | None = None,
              payloads: bool = False) -> Parts:
        """The run's :class:`_parts.Parts` in ``folder`` (inside the run folder), started.

        The one resume mechanism (collective): without ``--resume`` the parts of an earlier
        run are deleted; see :meth:`_parts.Parts.begin` for ``count`` and ``payloads``.
        """
        return Parts(self.file(folder), names).begin(self.comm, self.resumed, count, payloads)

    def open(self) -> RunFolder:
        """Check, lock and record (rank 0 decides; collective). Returns ``self``."""
        verdict, note = None, None
        if self.comm.rank == 0:
            try:
                verdict, note = self._open_rank0(), self._note
            except Exception as err:  # noqa: BLE001 - turned into the same verdict on all ranks
                verdict = f"{self.option} = {self.path!r}: {type(err).__name__}: {err}"
            if verdict is not None:
                self._unlock()
        verdict, self.resumed = self.comm.bcast((verdict, self.resumed), root=0)
        if verdict is not None:
            raise ParameterError(verdict)
        if note:
            say(note, err=True)
        _supervise.register_folder(self)
        return self

    def close(self, failed: bool = False) -> None:
        """Release the lock (rank 0); idempotent. ``failed``: a record without outputs goes.

        ``failed`` also removes this process's own temporary files (every rank's): a signal's
        handler exits without running the ``finally`` of a write it interrupted.
        """
        if failed:
            remove_partials(self.path, mine_only=True)
        if failed and self._locked and not self.holds_outputs():
            with contextlib.suppress(OSError):
                os.remove(self.file(RECORD))
        self._unlock()
        if not failed:  # a failed run's folder stays known to _supervise for its last line
            _supervise.unregister_folder(self)

    def holds_outputs(self) -> bool:
        """Whether the folder holds anything besides its record, lock and partial files."""
        for top, dirs, files in os.walk(self.path):
            dirs[:] = [d for d in dirs if PARTIAL not in d]
            if any(PARTIAL not in f and (top != self.path or f not in (RECORD, LOCK))
                   for f in files):
                return True
        return False

    def __enter__(self) -> RunFolder:
        return self.open()

    def __exit__(self, exc_type: object, *exc: object) -> None:
        self.close(failed=exc_type is not None)

    # -- rank 0
    def _open_rank0(self) -> str | None:
        out, opt = self.path, self.option
        if os.path.exists(out) and not os.path.isdir(out):
            return f"{opt} = {out!r} exists and is not a folder"
        if not os.path.isdir(out):
            if self.resume:
                return (f"--resume: {opt} = {out!r} does not exist, so there is nothing to "
                        "continue; check the folder, or start without --resume")
            try:
                os.makedirs(out)
            except OSError as err:
                return f"{opt} = {out!r} cannot be created: {err.strerror or err}"
        msg = self._lock() or self._check_content()
        if msg:
            return msg
        remove_partials(self.path)
        return self._write_record()

    def _lock(self) -> str | None:
        host = socket.gethostname()
        info = {"pid": os.getpid(), "host": host,
                "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "command": command()}
        tmp = f"{self._lock_path}{PARTIAL}{os.getpid()}"
        try:
            with open(tmp, "w") as fh:
                fh.write(dumps(info))
        except OSError as err:
            with contextlib.suppress(OSError):
                os.remove(tmp)
            return f"{self.option} = {self.path!r} is not writable: {err.strerror or err}"
        try:
            for _ in range(3):
                try:
                    os.link(tmp, self._lock_path)  # atomic, fails if a lock exists
                except FileExistsError:
                    other = self._read_lock()
                    why = _stale_lock(self._lock_path, other, host)
                    if why is None:
                        return (f"{self.option} = {self.path!r} is in use by another run (pid "
                                f"{other.get('pid')} on {other.get('host')} since "
                                f"{other.get('time')}); wait for it, or use another folder (if "
                                f"no such run is alive, delete {self._lock_path})")
                    with contextlib.suppress(FileNotFoundError):
                        os.remove(self._lock_path)
                    self._note = f"note: took over the stale lock {self._lock_path} ({why})"
                    continue
                except OSError as err:
                    return (f"{self.option} = {self.path!r} is not writable: "
                            f"{err.strerror or err}")
                self._locked = True
                atexit.register(self._unlock)
                return None
        finally:
            with contextlib.suppress(OSError):
                os.remove(tmp)
        return f"{self.option} = {self.path!r}: could not take the lock {self._lock_path}"

    def _read_lock(self) -> dict:
        try:
            with open(self._lock_path) as fh:
                other = json.load(fh)
        except (OSError, ValueError):
            return {}
        return other if isinstance(other, dict) else {}

    def _unlock(self) -> None:
        if not self._locked:
            return
        self._locked = False
        if self._read_lock().get("pid") == os.getpid():
            with contextlib.suppress(OSError):
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
            what = describe_difference(old.get("parameters"), self.parameters)
            if what is None:
                self.resumed = self.resume
                return None
            if self.resume:
                return (f"--resume: {out!r} holds a run with other parameters ({what}); "
                        "give the same parameters or another folder")
            return (f"{opt} = {out!r} holds another run ({what}); use another folder, or "
                    "delete it")
        names = [f for f in os.listdir(out) if f != LOCK and PARTIAL not in f]
        foreign = sorted(f for f in names if not any(fnmatch.fnmatch(f, p) for p in self.outputs))
        if foreign:
            return (f"{opt} = {out!r} holds files that are not this workflow's outputs "
                    f"({foreign[0]}{', ...' if len(foreign) > 1 else ''}): use another folder")
        if self.resume and names:
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
            with atomic_open(path) as fh:
                fh.write(dumps(record, indent=1) + "\n")
        except OSError as err:
            return f"{self.option} = {self.path!r} is not writable: {err.strerror or err}"
        return None
