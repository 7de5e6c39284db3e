"""The fastest modes of several sweeps against k (e.g. a damage zone against a homogeneous body).

    python workflows/fastest_modes.py --run "homogeneous=workflows/results/sweep_k"
        --run "damage zone=DIR" [--run NAME=DIR ...] --out workflows/results/damage_zone

Reads the ``spectrum.csv`` and ``summary.json`` of ``sweep_k.py`` runs (every eigenvalue in
the region R at every swept k) and, per run, takes at every k the fastest eigenvalue and the
second fastest (:func:`forms.studies.sweep.envelope`), the peak over k and the k ranges in
which one label leads (:func:`forms.studies.sweep.envelope_changes`: whether another mode
overtakes the peak's). Nothing is computed anew: the rows carry their sweep's certificate
(see each run's ``summary.json``, copied into this run's ``summary.json``).

Writes ``fastest.csv`` (run, k, label and Lambda of the fastest row, the second's label and
growth rate), ``summary.json`` (per run: its parameters, slider, region, certificate, peak and
leaders) and ``fastest_modes.png`` (growth rate of every row, thin, and the fastest, thick).
"""

from __future__ import annotations

import argparse
import csv
import json
import os

import _cli

from forms.studies.sweep import envelope, envelope_changes

PETSC_PREFIXES: tuple[str, ...] = ()
OUTPUTS = ("fastest.csv", "summary.json", "fastest_modes.png", "run.json", "run.lock")
FIELDS = ("run", "k", "label", "re_lambda", "im_lambda", "second_label", "second_re_lambda")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    ap = _cli.make_parser(__doc__, PETSC_PREFIXES, petsc=False)
    ap.add_argument("--run", action="append", default=[], metavar="NAME=DIR",
                    help="a sweep_k.py output folder and its name in the picture (repeat; 2 to 8)")
    ap.add_argument("--out", default=os.path.join("out", "fastest_modes"), help="output folder")
    return ap


def validate(args: argparse.Namespace) -> dict[str, str]:
    """The runs ``{name: folder}``; every folder holds a finished sweep on one common k grid."""
    if not 2 <= len(args.run) <= 8:
        raise _cli.ParameterError(f"--run given {len(args.run)} times, outside its allowed "
                                  "range 2..8")
    runs: dict[str, str] = {}
    grids = []
    for spec in args.run:
        name, sep, folder = spec.rpartition("=")
        if not sep or not name.strip() or name.strip() in runs:
            raise _cli.ParameterError(f"--run = {spec!r}: NAME=DIR with a new, non-empty NAME")
        try:
            with open(os.path.join(folder, "summary.json")) as fh:
                grids.append(json.load(fh)["k"]["spec"])
        except (OSError, ValueError, KeyError):
            raise _cli.ParameterError(f"--run = {spec!r}: {folder}/summary.json of a finished "
                                      "sweep_k.py run cannot be read") from None
        runs[name.strip()] = folder
    if len(set(grids)) != 1:
        raise _cli.ParameterError(f"--run: the sweeps' k grids differ ({', '.join(grids)}); "
                                  "one common grid is needed")
    return runs


def main(comm: object = None, argv: list[str] | None = None) -> int:
    """Read the runs, write the table, summary and picture (rank 0)."""
    args, comm = _cli.start(build_parser(), argv, comm)
    runs = validate(args)
    with _cli.RunFolder(comm, args.out, "fastest_modes", {"runs": runs},
                        outputs=OUTPUTS) as run:
        if comm.rank != 0:
            return 0
        table, per_run, rows_of = [], {}, {}
        for name, folder in runs.items():
            with open(os.path.join(folder, "spectrum.csv")) as fh:
                rows_of[name] = list(csv.DictReader(fh))
            with open(os.path.join(folder, "summary.json")) as fh:
                s = json.load(fh)
            with open(os.path.join(folder, "run.json")) as fh:
                material = json.load(fh)["parameters"].get("material", "homogeneous")
            env = envelope(rows_of[name])
            table += [{"run": name, **e} for e in env]
            per_run[name] = {"folder": folder, "parameters": s["parameters"],
                             "slider": material, "region": s["region"],
                             "check_exact": s.get("check_exact", True), "certificate": {
                                 key: s["certificate"][key] for key in ("k_values", "k_closed",
                                                                        "rows", "rows_ok")},
                             **envelope_changes(env)}
        with _cli.atomic_open(run.file("fastest.csv"), "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(FIELDS))
            w.writeheader()
            w.writerows({f: (repr(v) if isinstance(v, float) else v) for f, v in r.items()}
                        for r in table)
        _cli.write_json(run.file("summary.json"), {"runs": per_run, "versions": _cli.versions(),
                                                   "command": _cli.command()})
        first = next(iter(per_run.values()))["parameters"]
        plot(run.file("fastest_modes.png"), rows_of, table, {"runs": runs, "params": first})
        for name, r in per_run.items():
            pk = r["peak"]
            _cli.say(f"{name}: peak {pk['label']} at k = {pk['k']:.4g}, Re Lambda = "
                     f"{pk['re_lambda']:.6g}; leaders: " + ", ".join(
                         f"{x['label']} ({x['k_from']:.3g}..{x['k_to']:.3g})"
                         for x in r["leaders"]))
    return 0


def plot(path: str, rows_of: dict[str, list[dict]], table: list[dict], meta: dict) -> None:
    """fastest_modes.png: Re Lambda of every row (points) and of the fastest (line), per run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.8))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for j, (name, rows) in enumerate(rows_of.items()):
        c = colors[j % len(colors)]
        ax.plot([float(r["k"]) for r in rows], [float(r["re_lambda"]) for r in rows], ".",
                color=c, ms=2.5, alpha=0.35)
        env = [e for e in table if e["run"] == name]
        ax.plot([e["k"] for e in env], [e["re_lambda"] for e in env], "-", color=c, lw=2,
                label=f"{name}: fastest in R")
        pk = max(env, key=lambda e: e["re_lambda"])
        ax.plot(pk["k"], pk["re_lambda"], "o", color=c, mfc="none", ms=8)
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel("wavenumber k")
    ax.set_ylabel(r"growth rate Re $\Lambda$")
    p = meta["params"]
    ax.set_title("every eigenvalue in R (points) and the fastest (line); circle: peak over k\n"
                 + ", ".join(f"{n} = {p[n]}" for n in ("bc", "f", "gamma", "beta", "Delta", "H")),
                 fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _cli.save_figure(fig, path, dpi=130, metadata=_cli.png_metadata(meta, "fastest modes"))
    plt.close(fig)


if __name__ == "__main__":
    _cli.run(main)
