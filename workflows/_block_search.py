"""The per-length solve of ``finite_block.py``: targets near the strip's branches, or a box.

``--search targets`` solves near the infinite strip's branch targets
(:func:`forms.studies.block.most_unstable_block_mode`); ``--search complete`` returns every
eigenvalue in a box with its certificate (:func:`forms.studies.block.block_spectrum`: count by the
argument principle, conjugate symmetry, P(p+1) estimate). Rows are written here (rank 0).
"""

from __future__ import annotations

import argparse
import csv
import os

import _cli

from forms.studies import block

#: Per-length spectrum file of ``--search complete``.
SPECTRUM_CSV = "finite_block_spectrum.csv"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """``--search`` and ``--box``."""
    p.add_argument("--search", choices=("complete", "targets"), default="targets",
                   help="complete: every eigenvalue in --box, counted by the argument principle"
                        " (prefixes block_region_, block_region_det_); targets: eigenvalues near"
                        " the infinite strip's branches only (prefix block_)")
    p.add_argument("--box", default="auto",
                   help="RE_MIN:RE_MAX:IM_MAX of the complete search (Im in [-IM_MAX, IM_MAX]);"
                        " auto: Re from 0.5 to 2 times the strip's reference growth, |Im| up"
                        " to 1.5 times its frequency (not a proven bound)")


def parse_box(text: str) -> tuple[float, float, float] | None:
    """``--box`` as ``(re_min, re_max, im_max)``; ``None`` for ``auto``."""
    if text.strip() == "auto":
        return None
    try:
        re_min, re_max, im_max = (float(v) for v in text.split(":"))
    except ValueError:
        raise _cli.ParameterError(f"--box {text!r}: give RE_MIN:RE_MAX:IM_MAX or auto") from None
    if not (-1 < re_min < re_max and im_max > 0):
        raise _cli.ParameterError(f"--box {text!r} is outside its allowed range"
                                  " (-1 < RE_MIN < RE_MAX, IM_MAX > 0)")
    return re_min, re_max, im_max


def box_for(box: tuple[float, float, float] | None, lam_inf: complex) -> tuple[float, ...]:
    """The searched box ``(re_min, re_max, im_min, im_max)``."""
    if box is None:
        g, w = abs(lam_inf.real), abs(lam_inf.imag)
        box = (0.5 * g, 2.0 * g, 1.5 * max(w, 1.0))
    return box[0], box[1], -box[2], box[2]


def start_spectrum(out: str, resumed: bool) -> None:
    """Header of the spectrum CSV unless resumed onto an existing one (rank 0)."""
    path = os.path.join(out, SPECTRUM_CSV)
    if not (resumed and os.path.exists(path)):
        with _cli.atomic_open(path, "w", newline="") as f:
            csv.writer(f).writerow(block.SPECTRUM_COLUMNS)


def solve_length(comm, args: argparse.Namespace, params, L: float, ref, keep_mode: bool,
                 certificates: dict) -> tuple[block.BlockMode, bool]:
    """One length by ``args.search``; the spectrum rows appended and the certificate kept.

    Returns the fastest mode found and whether the length is done: a mode found (targets), or
    the count closed (complete; an empty box that counts 0 is an answer: no mode in it).
    """
    if args.search == "targets":
        mode = block.most_unstable_block_mode(
            comm, params, L, cells_per_unit=args.cells_per_unit, ny=args.ny,
            degree=args.degree, lateral=args.lateral, targets=ref.targets, nev=args.nev,
            keep_mode=keep_mode)
        return mode, mode.eigenvalue is not None
    spec = block.block_spectrum(
        comm, params, L, cells_per_unit=args.cells_per_unit, ny=args.ny, degree=args.degree,
        lateral=args.lateral, box=box_for(parse_box(args.box), ref.lam_inf), nev=args.nev,
        estimate=True, keep_mode=keep_mode)
    if comm.rank == 0:
        with open(os.path.join(args.out, SPECTRUM_CSV), "a", newline="") as f:
            csv.writer(f).writerows([[f"{v:.12g}" if isinstance(v, float) else v for v in r]
                                     for r in spec.rows()])
        certificates[f"{L:g}"] = spec.record()
    return spec.mode(), spec.closed
