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
is a finished piece of work. In a scene (:meth:`_runfolder.RunFolder.parts` starts them)::

    parts = run.parts("raw", "k{:05d}", count=len(k))  # cleared unless --resume
    parts.todo                                          # the numbers without a part
    parts.save(3, result.as_dict())                     # raw/k00003.json, when it is done
    parts.load(3), parts.load_all()                     # {name: payload}, in name order
"""

from __future__ import annotations

import fnmatch
import json
import os
import re
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
        names: Which files are parts: an ``fnmatch`` pattern of their names (other files in the
            folder are left alone), or for numbered parts a template such as ``"k{:05d}"``
            (part ``i`` is ``names.format(i)``; the pattern is the template with ``*`` for the
            field) whose parts may be named by their number.

    Attributes:
        present: After :meth:`begin`: the names present, or their payloads (``{name:
            payload}``).
        todo: After :meth:`begin` with ``count``: the numbers ``0 .. count - 1`` without a part.
    """

    def __init__(self, folder: str, names: str = "*") -> None:
        self.folder = folder
        self.template = names if "{" in names else None
        self.pattern = re.sub(r"\{[^}]*\}", "*", names)
        self.present: list[str] | dict[str, dict[str, Any]] = []
        self.todo: list[int] = []

    def name(self, part: str | int) -> str:
        """The name of a part given by its name or (numbered parts) its number."""
        if isinstance(part, str):
            return part
        if self.template is None:
            raise TypeError(f"parts {self.pattern!r} are not numbered: name them")
        return self.template.format(part)

    def begin(self, comm: Any, resumed: bool, count: int | None = None,
              payloads: bool = False) -> Parts:
        """Start the run's parts (collective); rank 0's view of what is there on every rank.

        Rank 0 creates the folder and, unless the run is ``resumed``, deletes the parts of an
        earlier run; sets :attr:`present` (names, or with ``payloads`` :meth:`load_all`) and,
        given ``count``, :attr:`todo`. Returns ``self``.
        """
        found = None
        if comm.rank == 0:
            os.makedirs(self.folder, exist_ok=True)
            if not resumed:
                self.clear()
            found = self.load_all() if payloads else self.names()
        self.present = comm.bcast(found, root=0)
        if count is not None:
            self.todo = [i for i in range(count) if self.name(i) not in self.present]
        return self

    def path(self, part: str | int, arrays: bool = False) -> str:
        """File of a part (``.npz`` if it holds arrays, else ``.json``)."""
        return os.path.join(self.folder, self.name(part) + (".npz" if arrays else ".json"))

    def save(self, part: str | int, payload: dict[str, Any]) -> dict[str, Any]:
        """Write a part atomically (replacing an older one of that name); returns ``payload``."""
        os.makedirs(self.folder, exist_ok=True)
        arrays = {k: v for k, v in payload.items() if isinstance(v, np.ndarray)}
        if not arrays:
            with atomic_open(self.path(part)) as fh:
                fh.write(dumps(payload, indent=1) + "\n")
            return payload
        rest = {k: v for k, v in payload.items() if k not in arrays}
        with atomic_open(self.path(part, arrays=True), "wb") as fh:
            np.savez(fh, **arrays, **{_JSON_KEY: np.array(dumps(rest))})
        return payload

    def load(self, part: str | int) -> dict[str, Any] | None:
        """The payload of a part (``None`` if there is none)."""
        for arrays in (False, True):
            path = self.path(part, arrays)
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
