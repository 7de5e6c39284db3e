"""The one resume mechanism: a run's finished pieces of work saved as *parts*, loaded back.

A resumable scene saves each finished piece of work as soon as it is done: one ``k`` of the
sweep (``raw/k#####.json``), one block length of ``finite_block`` (``raw/L*.json``), a
time-domain checkpoint (``checkpoint.json`` and ``checkpoint_rank*.npz``). On ``--resume``
(:class:`_runfolder.RunFolder` has checked that the parameters are the same) it loads the parts
and does only what they do not hold; without ``--resume`` it clears them first.

A part is a name and a payload (a dict). Payloads of JSON values are written as strict JSON
(``<name>.json``: NaN as ``null``, infinities as ``"inf"``, :func:`_provenance.dumps`); a
payload holding numpy arrays as ``<name>.npz`` (every array as written, the other values as
one JSON entry). Every part is written whole or not at all (:mod:`_writing`): a part on disk
is a finished piece of work.

    parts = Parts(run.file("raw"), "k*")
    done = parts.begin(comm, run.resumed)   # names present (cleared unless resumed)
    parts.save("k00003", result.as_dict())  # the rank that did the work, when it is done
    results = parts.load_all()              # {name: payload}
"""

from __future__ import annotations

import fnmatch
import json
import os
from typing import Any

import numpy as np
from _provenance import dumps
from _writing import atomic_open

__all__ = ["Parts"]

#: Key of the non-array values inside an ``.npz`` part.
_JSON_KEY = "__json__"
_SUFFIXES = (".json", ".npz")


class Parts:
    """The parts of one run in ``folder`` (a folder of the run, or the run folder itself).

    Args:
        folder: Where the parts live (created on the first :meth:`save`).
        pattern: ``fnmatch`` pattern of the part names that belong here (other files in the
            folder are not parts: :meth:`load_all` and :meth:`clear` leave them alone).
    """

    def __init__(self, folder: str, pattern: str = "*") -> None:
        self.folder = folder
        self.pattern = pattern

    def begin(self, comm: Any, resumed: bool) -> list[str]:
        """Start a run's parts (collective); the names present, rank 0's list on every rank.

        Rank 0 creates the folder and, unless the run is ``resumed``, deletes the parts of an
        earlier run.
        """
        names: list[str] | None = None
        if comm.rank == 0:
            os.makedirs(self.folder, exist_ok=True)
            if not resumed:
                self.clear()
            names = self.names()
        return comm.bcast(names, root=0)

    def path(self, name: str, arrays: bool = False) -> str:
        """File of the part ``name`` (``.npz`` if it holds arrays, else ``.json``)."""
        return os.path.join(self.folder, name + (".npz" if arrays else ".json"))

    def save(self, name: str, payload: dict[str, Any]) -> None:
        """Write the part ``name`` atomically (replacing an older one of the same name)."""
        os.makedirs(self.folder, exist_ok=True)
        arrays = {k: v for k, v in payload.items() if isinstance(v, np.ndarray)}
        if not arrays:
            with atomic_open(self.path(name)) as fh:
                fh.write(dumps(payload, indent=1) + "\n")
            return
        rest = {k: v for k, v in payload.items() if k not in arrays}
        with atomic_open(self.path(name, arrays=True), "wb") as fh:
            np.savez(fh, **arrays, **{_JSON_KEY: np.array(dumps(rest))})

    def load(self, name: str) -> dict[str, Any] | None:
        """The payload of the part ``name`` (``None`` if there is none)."""
        for arrays in (False, True):
            path = self.path(name, arrays)
            if os.path.exists(path):
                return _read(path)
        return None

    def names(self) -> list[str]:
        """Names of the parts present, sorted."""
        if not os.path.isdir(self.folder):
            return []
        out = set()
        for entry in os.listdir(self.folder):
            stem, ext = os.path.splitext(entry)
            if ext in _SUFFIXES and fnmatch.fnmatch(stem, self.pattern):
                out.add(stem)
        return sorted(out)

    def load_all(self) -> dict[str, dict[str, Any]]:
        """Every part present: ``{name: payload}`` in name order."""
        return {name: self.load(name) for name in self.names()}

    def clear(self) -> None:
        """Delete every part (a run that starts over; call on one rank)."""
        for name in self.names():
            for arrays in (False, True):
                if os.path.exists(self.path(name, arrays)):
                    os.remove(self.path(name, arrays))


def _read(path: str) -> dict[str, Any]:
    if path.endswith(".json"):
        with open(path) as fh:
            return json.load(fh)
    with np.load(path) as z:
        out = {k: z[k] for k in z.files if k != _JSON_KEY}
        if _JSON_KEY in z.files:
            out.update(json.loads(str(z[_JSON_KEY])))
    return out
