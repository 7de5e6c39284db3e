"""Output files written whole or not at all: a temporary name, then a rename.

A full disk, a kill or Ctrl-C in the middle of a write leaves at most a ``*.partial<pid>``
file, never a truncated file under its final name that a later run or ``--resume`` would trust
(:class:`_runfolder.RunFolder` deletes leftover partial files when it opens the folder).

- :func:`atomic_open`: ``open(path, "w")`` that renames on success, deletes on failure;
- :func:`write_json`: strict JSON (:func:`_provenance.dumps`), atomically;
- :func:`save_figure`: ``fig.savefig`` atomically (PNG with :func:`_provenance.png_metadata`);
- :func:`atomic_files`: several files written by a library under fixed names (XDMF + HDF5) in
  a temporary folder, moved into place when complete (the file that points to the others last).
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
from collections.abc import Iterator, Sequence
from typing import IO, Any

from _provenance import dumps

__all__ = ["PARTIAL", "atomic_files", "atomic_open", "is_no_space", "remove_partials",
           "save_figure", "write_json"]

#: Infix of temporary names (``<name>.partial<pid>``): a file with it is never an output.
PARTIAL = ".partial"


def _temp(path: str) -> str:
    return f"{path}{PARTIAL}{os.getpid()}"


def remove_partials(path: str, mine_only: bool = False) -> None:
    """Delete temporary files and folders (``*.partial<pid>``) of ``path``.

    Every one at the top of ``path``, or with ``mine_only`` this process's anywhere below it (a
    signal handler that exits skips the ``finally`` of the write it interrupted).
    """
    mine = f"{PARTIAL}{os.getpid()}"
    for top, dirs, files in os.walk(path):
        for name in dirs + files:
            if name.endswith(mine) if mine_only else PARTIAL in name:
                target = os.path.join(top, name)
                if os.path.isdir(target):
                    shutil.rmtree(target, ignore_errors=True)
                else:
                    with contextlib.suppress(OSError):
                        os.remove(target)
        dirs[:] = [d for d in dirs if PARTIAL not in d] if mine_only else []


def is_no_space(err: BaseException) -> bool:
    """Whether ``err`` (or an exception it was raised from) is a full disk or quota."""
    seen = 0
    while err is not None and seen < 10:
        if isinstance(err, OSError) and err.errno in (errno.ENOSPC, errno.EDQUOT):
            return True
        text = str(err).lower()
        if "no space left" in text or "disk quota" in text:
            return True
        err = err.__cause__ or err.__context__
        seen += 1
    return False


@contextlib.contextmanager
def atomic_open(path: str, mode: str = "w", **kwargs: Any) -> Iterator[IO]:
    """Open a temporary file beside ``path``; on a normal exit rename it to ``path``.

    On an exception the temporary file is removed and ``path`` is left as it was.
    """
    tmp = _temp(path)
    try:
        with open(tmp, mode, **kwargs) as fh:
            yield fh
            fh.flush()
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)


def write_json(path: str, obj: Any, indent: int | None = 1) -> None:
    """Write ``obj`` as strict JSON (NaN -> null, inf -> "inf") to ``path``, atomically."""
    text = dumps(obj, indent=indent)
    with atomic_open(path) as fh:
        fh.write(text + "\n")


def save_figure(fig: Any, path: str, **kwargs: Any) -> None:
    """``fig.savefig(path, **kwargs)`` through a temporary name (format from ``path``)."""
    kwargs.setdefault("format", os.path.splitext(path)[1].lstrip(".") or "png")
    tmp = _temp(path)
    try:
        fig.savefig(tmp, **kwargs)
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)


@contextlib.contextmanager
def atomic_files(folder: str, last: Sequence[str] = (), comm: Any = None) -> Iterator[str]:
    """A temporary folder inside ``folder`` for a library's files; moved into ``folder`` on success.

    Every file written there is moved, the names in ``last`` at the end in their order (the
    file that refers to the others, e.g. ``mode.xdmf`` after ``mode.h5``). With ``comm`` (a
    collective writer) rank 0 creates, moves and removes, between barriers. On an exception
    the temporary folder is removed and nothing is moved.
    """
    tmp = os.path.join(folder, f"{PARTIAL}{os.getpid()}")
    if comm is not None:
        tmp = comm.bcast(tmp, root=0)
    lead = comm is None or comm.rank == 0
    if lead:
        os.makedirs(tmp, exist_ok=True)
    if comm is not None:
        comm.barrier()
    try:
        yield tmp
        if comm is not None:
            comm.barrier()
        if lead:
            names = sorted(n for n in os.listdir(tmp) if n not in last) + list(last)
            for name in names:
                os.replace(os.path.join(tmp, name), os.path.join(folder, name))
    finally:
        if lead:
            shutil.rmtree(tmp, ignore_errors=True)
