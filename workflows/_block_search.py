"""The per-length solve of ``finite_block.py``: targets near the strip's branches, or a box.

``--search targets`` solves near the infinite strip's branch targets
(:func:`forms.studies.block.most_unstable_block_mode`), ``--search grid`` near a line of
targets ``RE - i Im`` (``--grid``: a probe of a frequency band, not a count); ``--search
complete`` returns every eigenvalue in a box with its certificate
(:func:`forms.studies.block.block_spectrum`: count by the argument principle, conjugate
symmetry, P(p+1) estimate). Rows are written here (rank 0).
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import os
import sys
import time
from collections.abc import Callable

import _cli
import numpy as np

from forms.studies import block

#: Per-length spectrum file of ``--search complete`` and its picture.
SPECTRUM_CSV = "finite_block_spectrum.csv"
SPECTRUM_PNG = "finite_block_spectrum.png"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """``--search``, ``--box``, ``--half``, ``--count-ranks`` and ``--count-reference``."""
    p.add_argument("--search", choices=("complete", "targets", "grid"), default="targets",
                   help="complete: every eigenvalue in --box, counted by the argument principle"
                        " (prefixes block_region_, block_region_det_); targets: eigenvalues near"
                        " the infinite strip's branches only (prefix block_); grid: near the"
                        " targets of --grid (prefix block_; a probe, nothing counted)")
    p.add_argument("--grid", default="0.3:5:125:1",
                   help="RE:IM_MIN:IM_MAX:STEP of --search grid: --nev eigenpairs nearest each"
                        " target RE - i Im, Im from IM_MIN to IM_MAX in steps of STEP (the"
                        " conjugates are eigenvalues too)")
    p.add_argument("--box", default="auto",
                   help="RE_MIN:RE_MAX:IM_MAX of the complete search (Im in [-IM_MAX, IM_MAX]);"
                        " auto: Re from 0.5 to 2 times the strip's reference growth, |Im| up"
                        " to the provable region's frequency at the mesh's resolvable k"
                        " (forms.studies.block.auto_box)")
    p.add_argument("--half", action="store_true",
                   help="complete search: count and solve the half box Im >= -0.05 (RE_MAX -"
                        " RE_MIN) only, the rest as conjugates (the block's operators are real)")
    p.add_argument("--count-ranks", choices=("split", "shared"), default="split",
                   help="complete search under MPI: split: each rank factorises its share of the"
                        " count's samples (serial MUMPS on a whole copy); shared: one parallel"
                        " LU per sample")
    p.add_argument("--count-reference", choices=("elastic", "none"), default="none",
                   help="complete search with RE_MIN > 0: elastic: the count's samples divided"
                        " by det of the frictionless block (eigenvalues on the imaginary axis;"
                        " prefix block_region_det_ref_): the same count, far fewer samples on"
                        " long blocks")


def parse_box(text: str, half: bool = False) -> tuple[float, float, float] | None:
    """``--box`` as ``(re_min, re_max, im_max)``; ``None`` for ``auto``.

    ``half`` (``--half``): ``IM_MAX`` must lie above the half box's lower edge too.
    """
    if text.strip() == "auto":
        return None
    try:
        re_min, re_max, im_max = (float(v) for v in text.split(":"))
    except ValueError:
        raise _cli.ParameterError(f"--box {text!r}: give RE_MIN:RE_MAX:IM_MAX or auto") from None
    if not (-1 < re_min < re_max and im_max > 0):
        raise _cli.ParameterError(f"--box {text!r} is outside its allowed range"
                                  " (-1 < RE_MIN < RE_MAX, IM_MAX > 0)")
    if half and im_max <= block.HALF_OFFSET * (re_max - re_min):
        raise _cli.ParameterError(f"--box {text!r} with --half: IM_MAX must exceed"
                                  f" {block.HALF_OFFSET:g} (RE_MAX - RE_MIN)")
    return re_min, re_max, im_max


def parse_grid(text: str) -> np.ndarray:
    """``--grid`` as its targets ``RE - i Im`` (at most :data:`MAX_GRID` of them)."""
    try:
        re_, lo, hi, step = (float(v) for v in text.split(":"))
    except ValueError:
        raise _cli.ParameterError(f"--grid {text!r}: give RE:IM_MIN:IM_MAX:STEP") from None
    if not (-1 < re_ < 10 and 0 <= lo <= hi and step > 0 and (hi - lo) / step < MAX_GRID):
        raise _cli.ParameterError(f"--grid {text!r} is outside its allowed range (-1 < RE < 10,"
                                  f" 0 <= IM_MIN <= IM_MAX, STEP > 0, at most {MAX_GRID}"
                                  " targets)")
    return re_ - 1j * np.arange(lo, hi + 0.5 * step, step)


#: Most targets of ``--grid``.
MAX_GRID = 2000


def target_count(args: argparse.Namespace) -> int:
    """Shift targets per length: ``--targets`` per branch, or the ``--grid`` line's."""
    return len(parse_grid(args.grid)) if args.search == "grid" else args.targets


def record(args: argparse.Namespace) -> dict:
    """The search's options for the run's record (``--resume`` must match them)."""
    return {"search": args.search, "box": args.box,
            **({"grid": args.grid} if args.search == "grid" else {}),
            **({"half": True} if args.half else {}),
            **({"count_reference": "elastic"} if args.count_reference == "elastic" else {})}


def box_for(box: tuple[float, float, float] | None, lam_inf: complex, params,
            args: argparse.Namespace) -> tuple[float, ...]:
    """The searched box ``(re_min, re_max, im_min, im_max)`` (``auto``: :func:`block.auto_box`)."""
    if box is None:
        return block.auto_box(params, lam_inf, args.cells_per_unit, args.degree)
    return box[0], box[1], -box[2], box[2]


def write_spectrum(out: str, certificates: dict) -> None:
    """The spectrum CSV, whole, from the certificates' rows (rank 0; complete search only).

    The rows live in each length's certificate, which is saved in the length's part: a
    resumed run rewrites the file from the parts, so no length appears twice.
    """
    rows = [r for key in sorted(certificates, key=float)
            for r in certificates[key].get("spectrum", [])]
    if not any("spectrum" in c for c in certificates.values()):
        return
    with _cli.atomic_open(os.path.join(out, SPECTRUM_CSV), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(block.SPECTRUM_COLUMNS)
        w.writerows(rows)


#: Seconds between two progress lines of one length's complete search (rank 0, stderr).
PROGRESS_EVERY = 30.0


def progress_printer(comm, L: float, every: float = PROGRESS_EVERY) -> Callable[[str], None]:
    """Rank 0 writes ``L = 32: <line>`` at most every ``every`` seconds, above the lengths' bar.

    The complete search of one long block runs for tens of minutes inside one step of the bar:
    its count's samples and its tiles (``forms.studies.block.block_spectrum``'s ``progress``).
    """
    from tqdm import tqdm

    last = [time.perf_counter()]

    def report(line: str) -> None:
        now = time.perf_counter()
        if comm.rank == 0 and now - last[0] >= every:
            last[0] = now
            tqdm.write(f"L = {L:g}: {line}", file=sys.stderr)

    return report


#: Folder of the run where a complete search's count keeps its samples as it computes them
#: (:class:`forms.solvers.region.SampleJournal`), one file per length; ``--resume`` continues
#: a stopped count from it; the file goes once its length is saved.
JOURNALS = "count_samples"


def journal_path(out: str, L: float) -> str:
    """The count's sample journal of length ``L`` in the run folder ``out``."""
    return os.path.join(out, JOURNALS, f"L{float(L)!r}.csv")


def drop_journal(out: str, L: float) -> None:
    """The count's sample journal of a saved length goes (its folder too, once empty)."""
    path = journal_path(out, L)
    if os.path.exists(path):
        os.remove(path)
        with contextlib.suppress(OSError):  # not empty: another length's journal is there
            os.rmdir(os.path.dirname(path))


def save_length(parts, out: str, L: float, record: dict) -> dict:  # noqa: ANN001
    """A finished length's part saved (``raw/L*.json``), then its count's journal dropped.

    Rank 0. Returns what ``parts.save`` returns.
    """
    saved = parts.save(f"L{float(L)!r}", record)
    drop_journal(out, L)
    return saved


def solve_length(comm, args: argparse.Namespace, params, L: float, ref, keep_mode: bool,
                 certificates: dict) -> tuple[block.BlockMode, bool]:
    """One length by ``args.search``; its certificate (with the spectrum's rows) kept.

    Returns the fastest mode found and whether the length is done: a mode found (targets, grid), or
    the count closed (complete; an empty box that counts 0 is an answer: no mode in it).
    """
    if args.search in ("targets", "grid"):
        targets = ref.targets if args.search == "targets" else list(parse_grid(args.grid))
        mode = block.most_unstable_block_mode(
            comm, params, L, cells_per_unit=args.cells_per_unit, ny=args.ny,
            degree=args.degree, lateral=args.lateral, targets=targets, nev=args.nev,
            keep_mode=keep_mode)
        return mode, mode.eigenvalue is not None
    box = box_for(parse_box(args.box), ref.lam_inf, params, args)
    spec = block.block_spectrum(
        comm, params, L, cells_per_unit=args.cells_per_unit, ny=args.ny, degree=args.degree,
        lateral=args.lateral, box=box, nev=args.nev, estimate=True, keep_mode=keep_mode,
        half=args.half, split_count=args.count_ranks == "split",
        divide=args.count_reference == "elastic", progress=progress_printer(comm, L),
        journal=journal_path(args.out, L))
    # the progress lines are at most every PROGRESS_EVERY seconds: the last one may be stale
    # ("tiles: 8 solved, 0 of 12 found" before the tiles that found them), so say the outcome
    outcome = progress_printer(comm, L, every=0.0)  # above the lengths' bar, like the progress
    outcome(f"found {spec.found}, counted {spec.counted}: "
            f"{'closed' if spec.closed else 'NOT closed'} ({spec.tiles} tiles, "
            + ", ".join(f"{k} {v:.0f} s" for k, v in spec.seconds.items()) + ")")
    if spec.closed and not spec.found:  # an answer, but not the fastest mode: say so
        _cli.say(f"L = {L:g}: no eigenvalue in the box (counted 0): every mode of this block "
                 f"with |Im| <= {box[3]:.6g} grows slower than Re = {box[0]:.6g}; to find the "
                 "fastest, lower RE_MIN of --box", err=True)
    if comm.rank == 0:
        certificates[f"{L:g}"] = {**spec.record(), "spectrum": [
            [f"{v:.12g}" if isinstance(v, float) else v for v in r] for r in spec.rows()]}
    return spec.mode(), spec.closed


def plot_spectrum(out: str, certificates: dict, lam_ref: complex, title: str, meta: dict) -> None:
    """Every eigenvalue of the complete search per length, with the boxes (rank 0).

    Left: ``Im`` against ``Re`` of every eigenvalue in the box, one colour per length, the
    boxes' outlines and the strip's reference growth; right: the fastest ``Re Lambda`` per
    length with ``found / counted``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = os.path.join(out, SPECTRUM_CSV)
    if not (certificates and os.path.exists(path)):
        return
    with open(path) as f:
        rows = list(csv.DictReader(f))
    lengths = sorted({float(r["L"]) for r in rows} | {float(v) for v in certificates})
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11.5, 4.6), width_ratios=(1.6, 1))
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, max(len(lengths), 1)))
    for L, col in zip(lengths, colours, strict=True):
        z = np.array([complex(float(r["re_lambda"]), float(r["im_lambda"])) for r in rows
                      if float(r["L"]) == L])
        cert = certificates.get(f"{L:g}")
        if cert is not None:
            a, b, c, d = cert["box"]
            ax.plot([a, b, b, a, a], [c, c, d, d, c], color=col, lw=0.8, ls="--")
        lab = f"L = {L:g}" + (f": {cert['found']} found / {cert['counted']} counted"
                              if cert is not None else "")
        ax.plot(z.real, z.imag, "o", ms=3, color=col, label=lab)
    ax.axvline(lam_ref.real, color="k", lw=0.8, ls=":",
               label=f"infinite strip, reference branch: {lam_ref.real:.4f}")
    ax.set_xlabel("Re $\\Lambda$")
    ax.set_ylabel("Im $\\Lambda$")
    ax.legend(fontsize=7, loc="upper right")
    ax.set_title(title, fontsize=9)
    done = [(float(v["L"]), v["fastest"]) for v in certificates.values() if v.get("fastest")]
    done.sort()
    if done:
        bx.plot([d[0] for d in done], [d[1][0] for d in done], "o-",
                label="fastest eigenvalue in the box")
    bx.axhline(lam_ref.real, color="k", lw=0.8, ls=":", label="infinite strip, reference")
    bx.set_xscale("log")
    bx.set_xlabel("block length $L$")
    bx.set_ylabel("Re $\\Lambda$ of the fastest")
    bx.legend(fontsize=7)
    fig.tight_layout()
    _cli.save_figure(fig, os.path.join(out, SPECTRUM_PNG), dpi=130,
                     metadata=_cli.png_metadata(meta, title))
    plt.close(fig)
