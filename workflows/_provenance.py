"""Provenance of the scenes' outputs: the command, versions, PNG text chunks, strict JSON.

- :func:`command`: the command line of this run, with ``mpirun -n N`` when there are several
  ranks; :func:`versions` (from :mod:`analytic.cli`, one definition in the project).
- :func:`png_metadata` / :func:`add_png_metadata`: PNG text chunks (``Description``: command,
  ``Comment``: parameters, ``Software``: versions).
- :func:`json_safe` / :func:`dumps` (from :mod:`analytic.cli`): standard JSON that any parser
  reads. Non-finite numbers follow one convention: ``NaN`` is written as ``null``, ``+inf`` /
  ``-inf`` as the strings ``"inf"`` / ``"-inf"`` (so a rigid substrate is ``"mu2": "inf"``);
  never bare ``NaN`` or ``Infinity``.
"""

from __future__ import annotations

import json
import shlex
import sys
from collections.abc import Sequence
from typing import Any

from _sharing import world_size

from analytic.cli import dumps, json_safe, versions

__all__ = ["add_png_metadata", "command", "describe_difference", "dumps", "json_dump", "json_safe",
           "png_metadata", "set_argv", "versions"]

_ARGV: dict[str, list[str] | None] = {"argv": None}


def set_argv(argv: Sequence[str]) -> None:
    """Record the arguments of this run (:func:`command` shows them)."""
    _ARGV["argv"] = list(argv)


def command() -> str:
    """The command line of this run (with ``mpirun -n N`` when there are several ranks)."""
    argv = _ARGV["argv"] if _ARGV["argv"] is not None else sys.argv[1:]
    cmd = shlex.join([sys.executable, sys.argv[0] if sys.argv else "", *argv])
    n = world_size()
    return f"mpirun -n {n} {cmd}" if n > 1 else cmd


def png_metadata(parameters: dict, title: str = "") -> dict[str, str]:
    """PNG text chunks of a workflow's figure: ``fig.savefig(path, metadata=...)``.

    ``Title``; ``Description``: the command line (:func:`command`); ``Comment``: the parameters
    (strict JSON); ``Software``: ``bimaterial-stability`` and :func:`versions` (JSON).
    """
    return {"Title": title, "Description": command(), "Comment": dumps(parameters),
            "Software": "bimaterial-stability " + dumps(versions())}


def add_png_metadata(path: str, parameters: dict, title: str = "") -> None:
    """Write :func:`png_metadata` into an existing PNG (e.g. a PyVista screenshot), atomically."""
    import os

    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    info = PngInfo()
    for key, value in png_metadata(parameters, title).items():
        info.add_text(key, value)
    tmp = f"{path}.tmp{os.getpid()}.png"
    try:
        with Image.open(path) as im:
            im.load()
            im.save(tmp, pnginfo=info)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


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


def describe_difference(old: Any, new: Any) -> str | None:
    """``"<path> = <old> there, <new> now"`` for the first difference of two records, or None."""
    diff = _first_difference(old, new)
    if diff is None:
        return None
    return f"{diff} = {_short(_lookup(old, diff))} there, {_short(_lookup(new, diff))} now"


def json_dump(obj: Any, fh: Any, **kwargs: Any) -> None:
    """``json.dump`` in strict JSON (:func:`dumps`; a ``default`` argument is not needed)."""
    kwargs.pop("default", None)
    fh.write(dumps(obj, **kwargs) + "\n")
