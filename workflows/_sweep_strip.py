"""``sweep_k.py --model strip``: every eigenvalue of the 2D Bloch cell at each k, certified.

At each ``k`` the cell of one wavelength ``2 pi / k`` (P``--strip-degree`` on
``--strip-cells`` x ``--strip-ny`` cells) is solved by
:func:`forms.studies.strip_sweep.strip_spectrum` (region solver, no exact root: MUMPS's
``log det`` counts, shift-and-invert over tiles finds; collective, the mesh on the whole
communicator) in the box ``re_min <= Re Lambda <= re_max``,
``|Im Lambda| <= strip_c_max k c_d + omega0`` (:func:`forms.studies.strip_sweep.strip_box`;
default ``strip_c_max = 1``, ``omega0 = 0``, not the cross-section sweep's region: see
:data:`WHY_BOX`; ``auto``: per ``k`` the default or, if taller, :data:`AUTO_MARGIN` times the
bound that holds the fastest mode of the resolved harmonics, :data:`FASTEST_STATEMENT`). Each
eigenvalue carries its convergence estimate against the degree ``p + 1`` cell on the same mesh
(``error_estimate``; ``status`` ``ok`` and certificate ``fe`` when the count closed and the
estimate is within ``--rtol``, default :data:`STRIP_RTOL` here), its harmonic ``h``
(wavenumber ``h k``) and its relative distance to the cross-section model's complete set at
``h k`` (rank 0, :func:`forms.studies.strip_sweep.section_sets`, the 1D
discretisation from ``min(--rtol, 1e-8)``, ``--degree``, ``--cells``). Over several ``k`` the
labels are ``c0, c1, ...`` by continuation of the eigenpairs in ``k`` (:data:`TRACK_STATEMENT`).
Every finished ``k`` is saved at once to ``DIR/raw/k#####.json`` (``--resume`` continues).
Rank 0 writes
``spectrum.csv`` (the section model's columns plus ``harmonic``, ``rel_distance_1d``),
``summary.json`` and ``dispersion.png`` (points coloured by harmonic).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import time

import _cli
import numpy as np
from _plot_dispersion import plot_dispersion

from analytic.numerics.spectrum import Region
from analytic.params import Params
from forms.solvers.certified import ROW_FIELDS, KResult
from forms.studies import strip_sweep as ss
from forms.studies import sweep

#: Every options prefix of the strip's PETSc/SLEPc objects (the region PEP, the count's LU and
#: the ``p + 1`` estimate's PEP).
PETSC_PREFIXES = ss.PREFIXES
FIELDS = (*ROW_FIELDS, *ss.EXTRA_FIELDS)
#: ``--rtol`` of the strip when not given: the P2 cell of 12 x 6 cells estimated 1.9e-4 at k = 4
#: (harmonic 1), the 1D cross-section model's 1e-8 is out of reach of a 2D cell.
STRIP_RTOL = 1e-3
#: The 1D reference sets are discretised for at least this accuracy (the section's default).
SECTION_RTOL = 1e-8
WHY_BOX = ("the cell holds every harmonic h k with its own spectrum: the cross-section sweep's "
           "region (c_max = 4, omega0 = 2 pi/(beta H)) at k = 4 held 102 eigenvalues of the "
           "cell (harmonics -9..9 in an exploratory run, most beyond what 12 cells per wavelength "
           "resolve) at 13 "
           "times the cost of the default box (528 s against 40 s, the count 93 % of it: "
           "workflows/results/strip_cost*)")
#: ``--strip-c-max auto``: the box's bound over the one that just holds the fastest mode (its
#: edge 5 % of the height above the mode, not through it).
AUTO_MARGIN = 1.05
#: What summary.json's fastest_mode says.
FASTEST_STATEMENT = (
    "the cell's modes of harmonic h are the cross-section model's at the wavenumber h k (-h: "
    "their conjugates, the same growth rates); for each h = 1 .. harmonics (those the cell "
    "resolves: 8 nodes per wavelength along x) the cross-section FE climbs its own provable "
    "region at h k (no exact root: the tail bound beyond it below the fastest eigenvalue "
    "inside); held: at every k each harmonic's fastest mode is proven and the fastest of them "
    "lies in the cell's box R, so the cell's most unstable in R is the fastest mode of the "
    "resolved harmonics (harmonics the cell does not resolve are not modelled by it)")
#: What the labels of a sweep over several k mean (forms.studies.sweep.label_by_continuation).
TRACK_STATEMENT = (
    "c0, c1, ...: continuation of the FE eigenpairs in k; each row at k_i is followed over 4 "
    "equal sub-steps to k_(i+1), on the cell of each sub-step, by one shift-and-invert solve at "
    "its secant predictor (forms.studies.strip_sweep.continue_values), and linked to the row "
    "there that is the mutually nearest one and within 1e-6 relative; a row without such a "
    "link starts a new label (numbered by first appearance, then |Im Lambda| to 9 digits, then "
    "Im Lambda)")
#: ... and of a single k.
LABEL_STATEMENT = "h<harmonic>_<j>: j by increasing |Im Lambda| within the harmonic"
#: Options of the section model that the strip takes only at their default: (attribute,
#: option, default, what the strip has instead).
NOT_FOR_STRIP = (("c_max", "--c-max", "auto", "its box's bound is --strip-c-max"),
                 ("solver", "--solver", "linear", "its solver is the region solve, options "
                  "-strip_region_*"),
                 ("layers_bound", "--layers-bound", "auto", "a homogeneous slider: its "
                  "harmonics' fastest modes are proven through the 1D model"))


#: The strip's own options with their defaults: another ``--model`` refuses them (one line,
#: exit 2) instead of ignoring them (session 36 noticed ``--model section --strip-cells 8``
#: run without a word).
STRIP_ONLY = (("strip_cells", "--strip-cells", 12), ("strip_ny", "--strip-ny", 6),
              ("strip_degree", "--strip-degree", 2), ("strip_c_max", "--strip-c-max", "1"))


def refuse_strip_options(args: argparse.Namespace) -> None:
    """Raise ParameterError if a strip option was changed for another ``--model``."""
    for name, option, default in STRIP_ONLY:
        if getattr(args, name) != default:
            raise _cli.ParameterError(f"{option} = {getattr(args, name)} is outside the allowed "
                                      f"options of --model {args.model}: it applies to --model "
                                      "strip only")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The strip's options (a group of ``sweep_k.py``'s parser)."""
    g = ap.add_argument_group("2D Bloch strip (--model strip; forms.studies.strip_sweep)")
    default = {name: value for name, _, value in STRIP_ONLY}
    g.add_argument("--strip-cells", type=int, default=default["strip_cells"],
                   help="cells along x per wavelength")
    g.add_argument("--strip-ny", type=int, default=default["strip_ny"], help="cells along y")
    g.add_argument("--strip-degree", type=int, default=default["strip_degree"],
                   help="Lagrange degree 1..4 (the estimate solves degree + 1)")
    g.add_argument("--strip-c-max", default=default["strip_c_max"],
                   help="box |Im Lambda| <= strip_c_max k c_d + omega0 (c_d: the slider's "
                   "largest; --omega0 0: none), Re Lambda in [--re-min, --re-max]; auto: per k "
                   "the default 1 or, if taller, 1.05 times the bound that holds the fastest "
                   "mode of the harmonics the cell resolves (the 1D model's at h k)")


def validate(args: argparse.Namespace) -> tuple[Params, np.ndarray]:
    """Check every input of ``--model strip``; raise ParameterError on the first bad one."""
    params = _cli.params_from_args(args)
    if not math.isfinite(params.H) or (params.two_body and not math.isfinite(params.H2)):
        raise _cli.ParameterError("H = inf (or H2 = inf) is outside its allowed range here: "
                                  "the Bloch cell needs finite H > 0 (and H2 > 0)")
    if args.layers or args.mu_profile or args.rho_profile or args.beta_profile:
        raise _cli.ParameterError("--layers and --*-profile are outside the allowed options of "
                                  "--model strip")
    for name, option, default, instead in NOT_FOR_STRIP:
        if getattr(args, name) != default:
            raise _cli.ParameterError(f"{option} = {getattr(args, name)} is outside its allowed "
                                      f"values for --model strip: {default} only ({instead})")
    if args.check_exact not in ("auto", "no"):
        raise _cli.ParameterError(f"--check-exact = {args.check_exact} is outside its allowed "
                                  "values auto | no for --model strip (no exact roots are used)")
    args.rtol = STRIP_RTOL if args.rtol is None else args.rtol
    _cli.positive_int("--strip-cells", args.strip_cells, 2, 1000)
    _cli.positive_int("--strip-ny", args.strip_ny, 1, 1000)
    _cli.positive_int("--strip-degree", args.strip_degree, 1, 4)
    _cli.check_section_options(args)  # the 1D sets' --degree, --cells, --rtol; --omega0
    args.strip_c_max = _strip_c_max(args.strip_c_max)
    if not (-1.0 < args.re_min < args.re_max and math.isfinite(args.re_max)):
        raise _cli.ParameterError(f"--re-min = {args.re_min}, --re-max = {args.re_max} are "
                                  "outside their allowed range -1 < re_min < re_max")
    return params, np.unique(_cli.parse_k(args.k))


def _strip_c_max(text: str) -> float | None:
    """``--strip-c-max``: a number > 0, or ``auto`` (``None``)."""
    if text == "auto":
        return None
    try:
        c = float(text)
    except ValueError:
        c = math.nan
    if not (math.isfinite(c) and c > 0):
        raise _cli.ParameterError(f"--strip-c-max = {text} is outside its allowed values: a "
                                  "number > 0, or auto")
    return c


def solve_k(comm: object, params: Params, k: float, args: argparse.Namespace,
            k_next: float | None = None) -> tuple[list[dict], dict]:
    """The strip at ``k`` and, on rank 0, its comparison with the 1D sets (collective).

    With ``k_next`` each eigenvalue is also continued there (the links of the labels).
    """
    t0 = time.perf_counter()
    fastest, c = [], args.strip_c_max
    if comm.rank == 0:  # each resolved harmonic's fastest mode, by the 1D model at h k
        fastest = ss.fastest_by_harmonic(
            params, k, ss.resolved_harmonics(args.strip_cells, args.strip_degree),
            min(args.rtol, SECTION_RTOL), args.degree, args.cells)
        for f in fastest:  # the --strip-c-max whose box would hold it
            z = complex(f["re_lambda"], f["im_lambda"])
            f["strip_c_max_needed"] = ss.c_max_holding(params, k, z, args.omega0)
        if c is None:  # auto: the default box, or taller to hold the fastest with a margin
            top = ss.fastest_of(fastest)
            c = max(1.0, AUTO_MARGIN * top["strip_c_max_needed"] if top else 1.0)
    c = comm.bcast(c)
    t_f = time.perf_counter()
    box = ss.strip_box(params, k, args.re_min, args.re_max, c, args.omega0)
    for f in fastest:
        f["in_box"] = ss.inside(complex(f["re_lambda"], f["im_lambda"]), box)
    mesh = {"cells_per_wavelength": args.strip_cells, "ny": args.strip_ny,
            "degree": args.strip_degree}
    spec = ss.strip_spectrum(comm, params, k, box, **mesh)
    if k_next is not None and len(spec.values):
        t_c = time.perf_counter()
        ks = np.linspace(k, k_next, sweep.TRACK_SUBSTEPS + 1)
        spec.next_values, _ = ss.continue_values(comm, params, ks, spec.values, **mesh)
        spec.seconds["continuation"] = time.perf_counter() - t_c
    t1 = time.perf_counter()
    rows, entry = [], {}
    if comm.rank == 0:
        sets = ss.section_sets(params, k, [*spec.harmonics, 1.0], spec.box,
                               min(args.rtol, SECTION_RTOL), args.degree, args.cells)
        dist, per = ss.compare_with_section(spec, sets)
        rows = ss.strip_rows(spec, dist, args.rtol)
        entry = {"k": float(k), "box": list(spec.box), "strip_c_max": c,
                 "unknowns": spec.unknowns,
                 "unknowns_estimate": spec.fine_unknowns, "counted": spec.counted,
                 "found": len(spec.values), "closed": spec.closed, "harmonics": per,
                 "fastest_by_harmonic": fastest,
                 "certificate": [r["certificate"] for r in rows],
                 "seconds": {**spec.seconds, "strip_total": t1 - t_f,
                             "section_sets": time.perf_counter() - t1,
                             "fastest_by_harmonic": t_f - t0}}
    return rows, entry


def run(comm: object, args: argparse.Namespace, outputs: tuple[str, ...]) -> int:
    """``sweep_k.py --model strip`` on ``comm`` (every rank calls this); the exit code."""
    params, ks = validate(args)
    config = {"model": "strip", "params": params.as_dict(), "k": [float(v) for v in ks],
              "re_min": args.re_min, "re_max": args.re_max,
              "strip_c_max": "auto" if args.strip_c_max is None else args.strip_c_max,
              "omega0": args.omega0, "rtol": args.rtol,
              "strip": {"cells_per_wavelength": args.strip_cells, "ny": args.strip_ny,
                        "degree": args.strip_degree},
              "section": {"degree": args.degree, "cells": args.cells}}
    with _cli.RunFolder(comm, args.out, "sweep_k", config, resume=args.resume, resumable=True,
                        outputs=outputs) as run_:
        t_start = time.perf_counter()
        parts = run_.parts("raw", "k{:05d}", count=len(ks))  # --resume: the k values left
        for i in parts.todo:
            k = float(ks[i])
            rows, entry = solve_k(comm, params, k, args,
                                  float(ks[i + 1]) if i + 1 < len(ks) else None)
            if comm.rank == 0:  # a KResult's fields (sweep.k_result_from_json) + the entry
                parts.save(i, KResult(k, rows, None, entry["counted"], tuple(entry["box"]),
                                      entry["closed"], "", entry["seconds"]["strip_total"]
                                      ).as_dict() | {"entry": entry})
                if not args.quiet:
                    _cli.say(f"k = {k:g}: {entry['found']} eigenvalues (counted "
                             f"{entry['counted']}), {entry['seconds']['strip_total']:.1f} s",
                             err=True)
        code = 0
        if comm.rank == 0:
            saved = [parts.load(i) for i in range(len(ks))]
            results = [sweep.k_result_from_json(d) for d in saved]
            per_k = [_entry_back(d["entry"]) for d in saved]
            rows = [r for res in results for r in res.rows]
            if len(results) > 1:  # c0, c1, ... over k, the same names in every run
                sweep.label_by_continuation(results)
                ss.canonical_labels(rows)
            summary = summarise(config, rows, per_k, comm.size, WHY_BOX)
            summary["resume"] = {"resumed": run_.resumed, "computed_k": len(parts.todo)}
            summary["timing_s"] = {"wall": time.perf_counter() - t_start}
            _write(run_.path, results, summary, params, not args.no_plot)
            code = report(summary, run_.path)
        code = comm.bcast(code)
    return code


def _entry_back(entry: dict) -> dict:
    """A saved ``k``'s entry read back from strict JSON: infinite distances restored."""
    for v in entry["harmonics"].values():
        if v["max_rel_distance"] in ("inf", "-inf"):
            v["max_rel_distance"] = float(v["max_rel_distance"])
    return entry


def summarise(config: dict, rows: list[dict], per_k: list[dict], ranks: int, why: str) -> dict:
    """``summary.json`` of the strip sweep (pure data)."""
    by_h: dict[str, float] = {}
    for e in per_k:
        for h, v in e["harmonics"].items():
            if v["max_rel_distance"] is not None:
                by_h[h] = max(by_h.get(h, 0.0), v["max_rel_distance"])
    ones = [e["harmonics"]["1"] for e in per_k]
    # a conjugate pair (harmonics h and -h, real parts equal to rounding): Im <= 0 first, as
    # the region solver orders them, so that serial and MPI runs name the same row
    best = max(rows, key=lambda r: (round(r["re_lambda"], 9), -r["im_lambda"]), default=None)
    ests = [r["error_estimate"] for r in rows if math.isfinite(r["error_estimate"])]
    open_k = [e["k"] for e in per_k if not e["closed"]]
    fastest = fastest_mode(per_k)
    if best is not None:  # as the section's: its row ok and every k's count closed
        best = best | {"certified": best["status"] == "ok" and not open_k,
                       "fastest_mode": fastest["held"] and _is_the_fastest(best, rows, per_k)}
    return {**config, "box_reason": why, "versions": _cli.versions(), "command": _cli.command(),
            "mpi": {"ranks": ranks}, "certificate": {
                "statement": "fe: the count (argument principle on MUMPS's log det) equals the "
                "eigenvalues found, and the row's estimate against degree p + 1 on the same "
                "mesh is within rtol; no exact root is used",
                "rows": len(rows), "rows_ok": sum(r["status"] == "ok" for r in rows),
                "k_not_closed": open_k},
            "accuracy": {"rtol": config["rtol"],
                         "max_error_estimate": max(ests) if ests else None,
                         "estimates_missing": len(rows) - len(ests)},
            "harmonic_1": {"strip": sum(v["strip"] for v in ones),
                           "section": sum(v["section"] for v in ones),
                           "max_rel_distance": by_h.get("1")},
            "max_rel_distance_by_harmonic": by_h, "most_unstable": best,
            "fastest_mode": fastest,
            "labels": TRACK_STATEMENT if len(per_k) > 1 else LABEL_STATEMENT, "per_k": per_k}


def fastest_mode(per_k: list[dict]) -> dict:
    """Whether the box held the fastest mode of the resolved harmonics at every ``k`` (pure data).

    At each ``k`` the fastest of the harmonics' fastest modes (``fastest_by_harmonic``, each
    proven by the 1D model's region at ``h k``) is held when every harmonic's was proven and it
    lies in the box; then the cell's most unstable in ``R`` at that ``k`` is it (to the cell's
    discretisation error). ``strip_c_max_needed``: the smallest ``--strip-c-max`` whose box
    holds the fastest mode at every ``k``.
    """
    held, missed, unproven, tops = [], [], [], []
    for e in per_k:
        fb = e.get("fastest_by_harmonic", [])
        top = ss.fastest_of(fb)
        if top is None or not all(f["proven"] for f in fb):
            unproven.append(e["k"])
        elif top is not None and top["in_box"]:
            held.append(e["k"])
        else:
            missed.append(e["k"])
        if top is not None:
            tops.append(top | {"k": e["k"]})
    best = max(tops, key=lambda f: f["re_lambda"], default=None)
    n = max((len(e.get("fastest_by_harmonic", [])) for e in per_k), default=0)
    return {"statement": FASTEST_STATEMENT, "harmonics": n, "held": not missed and not unproven,
            "k_held": held, "k_outside_box": missed, "k_not_proven": unproven, "fastest": best,
            "strip_c_max_needed": max((f["strip_c_max_needed"] for f in tops), default=None)}


def _is_the_fastest(best: dict, rows: list[dict], per_k: list[dict]) -> bool:
    """``best`` is the cell's row of the proven fastest mode at its ``k``.

    Of the rows at that ``k`` whose harmonic is the fastest mode's (``-h``: its conjugate),
    the nearest to it (either row of a conjugate pair: on a 2026-12-02 machine the pair's
    distances differed by rounding the other way and the line said "not it"). Not so when a
    faster row of another harmonic leads ``R`` (e.g. one the cell does not resolve, flagged by
    its estimate).
    """
    e = next(e for e in per_k if e["k"] == best["k"])
    top = ss.fastest_of(e.get("fastest_by_harmonic", []))
    if top is None:
        return False
    z = complex(top["re_lambda"], top["im_lambda"])

    def distance(r: dict) -> float:
        w = complex(r["re_lambda"], r["im_lambda"])
        return abs(w - (z if r["harmonic"] > 0 else z.conjugate()))

    mine = [r for r in rows if r["k"] == best["k"] and abs(r["harmonic"]) == top["harmonic"]]
    if not any(r is best for r in mine):
        return False
    # a conjugate pair's two rows are equally near to rounding (1e-15 apart): either is it
    return distance(best) <= min(map(distance, mine)) + 1e-12 * abs(z)


def _write(out: str, results: list[KResult], summary: dict, params: Params,
           plot: bool) -> None:
    with _cli.atomic_open(os.path.join(out, "spectrum.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(FIELDS))
        w.writeheader()
        w.writerows(sweep.csv_rows(results, FIELDS))
    _cli.write_json(os.path.join(out, "summary.json"), summary)
    if plot and any(res.rows for res in results):
        best = summary["most_unstable"]
        c = summary
        c_max = (max(e["strip_c_max"] for e in c["per_k"]) if c["strip_c_max"] == "auto"
                 else c["strip_c_max"])
        bound = "(auto per k)" if c["strip_c_max"] == "auto" else f"{c_max:g}"
        title = (f"2D Bloch cell (P{c['strip']['degree']}, {c['strip']['cells_per_wavelength']}"
                 f" x {c['strip']['ny']} cells): every eigenvalue with {c['re_min']:g} <= Re <= "
                 f"{c['re_max']:g}, |Im| <= {bound} k c_d + {c['omega0']:g}\n"
                 f"colour: harmonic h (wavenumber h k); f={params.f:g}, gamma={params.gamma:g}, "
                 f"beta={params.beta:g}, Delta={params.Delta:g}, H={params.H:g}, bc={params.bc}")
        region = Region(re_min=c["re_min"], re_max=c["re_max"], c_max=c_max)
        marks = [(e["k"], complex(f["re_lambda"], f["im_lambda"]),
                  f"fastest mode of harmonic {f['harmonic']} (1D model at {f['harmonic']} k)")
                 for e in c["per_k"] for f in e.get("fastest_by_harmonic", [])
                 if math.isfinite(f["re_lambda"])]
        plot_dispersion(os.path.join(out, "dispersion.png"), params, region, results, [],
                        None if best is None else best | {"branch": best["label"]},
                        c["params"], colour_by="harmonic", title=title, marks=marks,
                        box_edges=[(e["k"], e["box"][3]) for e in c["per_k"]])


def report(summary: dict, out: str) -> int:
    """Rank 0: the result line (and a warning if a count did not close or rows are flagged)."""
    cert, one = summary["certificate"], summary["harmonic_1"]
    code = 0
    if cert["k_not_closed"] or cert["rows_ok"] < cert["rows"]:
        code = 1
        print(f"warning: {cert['rows'] - cert['rows_ok']} of {cert['rows']} eigenvalue(s) "
              f"flagged, count not closed at k = {cert['k_not_closed']}; see status in "
              f"{out}/spectrum.csv", flush=True)
    best = summary["most_unstable"]
    lead = best is not None and best["fastest_mode"]
    top = "none" if best is None else (
        f"{best['label']} ({'certified' if best['certified'] else 'NOT certified'}) at k = "
        f"{best['k']:g}: Lambda = {best['re_lambda']:.6g} {best['im_lambda']:+.6g}i")
    def short(v: float | None) -> str:
        return "none" if v is None else f"{v:.3g}"

    print(f"strip: {cert['rows']} eigenvalues over {len(summary['per_k'])} k value(s), "
          f"{cert['rows_ok']} ok (largest estimate "
          f"{short(summary['accuracy']['max_error_estimate'])}, rtol "
          f"{summary['accuracy']['rtol']:g}); harmonic 1: {one['strip']} (1D: {one['section']}),"
          f" max relative distance {short(one['max_rel_distance'])}; most unstable "
          f"in R {top}; {_fastest_line(summary['fastest_mode'], lead)} -> {out}", flush=True)
    return code


def _fastest_line(fm: dict, lead: bool) -> str:
    """The result line's account of :func:`fastest_mode` (``lead``: the most unstable is it)."""
    f, n = fm["fastest"], fm["harmonics"]
    what = (f"the fastest mode of harmonics +-1..+-{n} (the 1D model's proven region at h k)")
    if f is None:
        return f"{what}: none found"
    z = f"h = {f['harmonic']} at k = {f['k']:g}: {f['re_lambda']:.6g} {f['im_lambda']:+.6g}i"
    if fm["held"] and lead:
        return f"{what} is in R at every k ({z}): R holds the fastest mode"
    if fm["held"]:
        return (f"{what} is in R at every k ({z}), but the most unstable in R is not it (a "
                "faster row of another harmonic: see its status)")
    why = []
    if fm["k_outside_box"]:
        why.append(f"outside R at {len(fm['k_outside_box'])} k (--strip-c-max "
                   f"{math.ceil(fm['strip_c_max_needed'] * 10) / 10:g} would hold it)")
    if fm["k_not_proven"]:
        why.append(f"not proven at k = {fm['k_not_proven']}")
    return f"{what}: {z}, {'; '.join(why)}: R NOT proven to hold the fastest mode"
