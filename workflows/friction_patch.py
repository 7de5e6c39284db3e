"""A finite block whose interface has a friction patch: fastest global mode against ``Lp``.

The block ``0 < x < L`` on the rigid substrate; on ``|x - L/2| < Lp/2`` the friction parameters
are the patch's (``--patch-delta``, ``--patch-f``, ``--patch-gamma``), elsewhere those of the
usual parameter options. ``Delta < 0`` is velocity weakening (``analytic.params``): the default
is a weakening patch (``Delta = -0.3``) in a strengthening interface (``--Delta 0.7``, with
``--gamma 0.1`` by default here: the uniform strengthening block is then stable). ``--reverse``
swaps the two sets (a strengthening patch in a weakening interface).

For every ``Lp``: every eigenvalue in the box (``--box``) found and counted by the argument
principle (``forms.studies.patch.patch_spectrum``, options prefix ``patch_region_``, its LU
``patch_region_det_``), the fastest kept with its P+1 estimate. As each ``Lp`` finishes, its
row and certificate are saved as a part ``raw/Lp<Lp>.json`` (:mod:`_parts`; ``--resume`` keeps
them and computes only the other lengths, else they are cleared) and ``friction_patch.csv`` and
``friction_patch.json`` are written from the parts; at the
end ``friction_patch.png`` (``max Re Lambda`` against ``Lp``, the critical length ``Lc`` where
it crosses 0, interpolated, and the published nucleation estimates) and ``patch_mode_<Lp>.png``
(the fastest mode at ``--pictures`` lengths).

Example::

    ./run python workflows/friction_patch.py --out workflows/results/friction_patch
"""

from __future__ import annotations

import argparse
import csv

import _cli
import _plot_patch
import _plots
import numpy as np

from forms.studies import patch as fp
from forms.studies.strip_mode import interface_of

PETSC_PREFIXES = ("patch_region_", "patch_region_det_")
OUTPUTS = ("friction_patch.csv", "friction_patch.json", "friction_patch.png", "patch_mode_*.png",
           "raw")
COLUMNS = ("Lp", "re_lambda", "im_lambda", "residual", "estimate", "found", "counted", "closed")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    p = _cli.make_parser(__doc__, PETSC_PREFIXES)
    _cli.add_param_arguments(p)
    p.set_defaults(gamma=0.1)
    p.add_argument("--patch-delta", type=float, default=-0.3, help="Delta on the patch")
    p.add_argument("--patch-f", type=float, default=None, help="f on the patch (default: --f)")
    p.add_argument("--patch-gamma", type=float, default=None,
                   help="gamma on the patch (default: --gamma)")
    p.add_argument("--reverse", action="store_true", help="swap patch and outside values")
    p.add_argument("--length", type=float, default=8.0, help="block length L")
    p.add_argument("--lp", default="0.5:8:16", help="patch lengths (start:stop:count or list)")
    p.add_argument("--box", default="-0.05,0.5,-3,3", help="re_min,re_max,im_min,im_max")
    p.add_argument("--cells-per-unit", type=int, default=4, help="cells per unit length in x")
    p.add_argument("--ny", type=int, default=3, help="cells along y")
    p.add_argument("--degree", type=int, default=2, help="Lagrange degree")
    p.add_argument("--nev", type=int, default=8, help="eigenpairs per tile solve")
    p.add_argument("--lateral", choices=("free", "roller", "clamped"), default="free")
    p.add_argument("--pictures", type=int, default=3, help="mode pictures (evenly spaced Lp)")
    p.add_argument("--resume", action="store_true", help="keep the finished Lp (raw/Lp*.json)")
    p.add_argument("--out", default="out/friction_patch", help="output directory")
    return p


def validate(args: argparse.Namespace):
    """Options -> (outside params, patch values, Lp grid, box); one-line errors, exit 2."""
    params = _cli.params_from_args(args)
    inside = params.replace(Delta=args.patch_delta, f=params.f if args.patch_f is None
                            else args.patch_f, gamma=params.gamma if args.patch_gamma is None
                            else args.patch_gamma)  # validates the patch values
    if args.reverse:
        params, inside = inside, params
    if not (args.length > 0 and np.isfinite(args.length)):
        raise _cli.ParameterError(f"--length = {args.length} is outside 0 < L < inf")
    lp = np.unique(_cli.parse_k(args.lp, name="--lp"))
    if lp.max() > args.length:
        raise _cli.ParameterError(f"--lp = {lp.max():g} is outside 0 < Lp <= L = {args.length:g}")
    try:
        box = [float(v) for v in args.box.split(",")]
    except ValueError:
        box = []
    if len(box) != 4 or not (-1 < box[0] < box[1] and box[2] < box[3]):
        raise _cli.ParameterError(f"--box = {args.box!r} is not re_min,re_max,im_min,im_max"
                                  " with -1 < re_min < re_max, im_min < im_max")
    for name in ("cells_per_unit", "ny", "nev"):
        _cli.positive_int("--" + name.replace("_", "-"), getattr(args, name), 1)
    _cli.positive_int("--degree", args.degree, 1, 4)
    _cli.check_block_size(args.length, args.cells_per_unit, args.ny, args.degree,
                          params.two_body, "--length")
    return params, inside, lp, box


def main(comm=None, argv: list[str] | None = None) -> int:
    """Scan the patch lengths; exit code 1 if some count did not close."""
    args, comm = _cli.start(build_parser(), argv, comm)
    params, inside, lp, box = validate(args)
    record = {"outside": params.as_dict(), "patch": inside.as_dict(), "L": args.length,
              "box": box, "cells_per_unit": args.cells_per_unit, "ny": args.ny,
              "degree": args.degree, "lateral": args.lateral}
    with _cli.RunFolder(comm, args.out, "friction_patch", record, resume=args.resume,
                        resumable=True, outputs=OUTPUTS) as run:
        csv_path, json_path = run.file("friction_patch.csv"), run.file("friction_patch.json")
        parts = run.parts("raw", "Lp*", payloads=True)  # one per finished Lp (--resume)
        done = {float(d["row"]["Lp"]): d for d in parts.present.values()}
        shown = set(lp[np.linspace(0, len(lp) - 1, min(args.pictures, len(lp))).astype(int)])
        todo = [x for x in lp if float(x) not in done or x in shown]
        _cli.say_plan(comm, f"{len(todo)} patch length(s)", fp.estimate_seconds(_cli.block_unknowns(
            args.length, args.cells_per_unit, args.ny, args.degree, params.two_body), len(todo)))
        for x in lp:
            if float(x) in done and x not in shown:
                continue
            spec = fp.patch_spectrum(
                comm, params, args.length, fp.Patch(float(x), inside.Delta, inside.f,
                                                     inside.gamma),
                cells_per_unit=args.cells_per_unit, ny=args.ny, degree=args.degree,
                lateral=args.lateral, box=box, nev=args.nev, keep_mode=x in shown)
            part = {"row": _row(x, spec), "certificate": spec.record()}
            done[float(x)] = parts.save(f"Lp{float(x)!r}", part) if comm.rank == 0 else part
            data = interface_of(spec.u, params) if spec.u is not None else None
            if comm.rank == 0:
                _write(csv_path, json_path, done, record)
                if data is not None:
                    z = spec.values[0]
                    _plots.plot_interface(data, run.file(f"patch_mode_{x:g}.png"),
                                          f"fastest mode, Lp = {x:g}: Lambda = {z:.5f}", record)
        weak = min(params, inside, key=lambda q: q.Delta)  # the velocity-weakening side
        return _finish(comm, args, done, record, weak, run)


def _row(x: float, spec) -> dict:
    """The CSV row of one ``Lp`` as the strings csv writes (so a part keeps ``nan``)."""
    z = spec.values[0] if spec.found else complex("nan")
    return {c: str(float(v) if isinstance(v, float) else v) for c, v in zip(COLUMNS, (
        float(x), z.real, z.imag, spec.residuals[0] if spec.found else np.nan,
        spec.estimates[0] if spec.found else np.nan, spec.found, spec.counted,
        "yes" if spec.closed else "no"), strict=True)}


def _write(csv_path: str, json_path: str, done: dict, record: dict) -> None:
    """The CSV and JSON from the finished lengths' parts ``{Lp: part}``, by increasing Lp."""
    with _cli.atomic_open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(done[x]["row"] for x in sorted(done))
    certs = {f"{x:g}": done[x]["certificate"] for x in sorted(done)}
    _cli.write_json(json_path, {**record, "certificates": certs, "versions": _cli.versions(),
                                "command": _cli.command()})


def _finish(comm, args, done, record, weak, run) -> int:
    rows = [done[x]["row"] for x in sorted(done)]
    lp = np.array([float(r["Lp"]) for r in rows])
    g = np.array([float(r["re_lambda"]) for r in rows])
    closed = np.array([r["closed"] == "yes" for r in rows])
    lc = fp.critical_length(lp, g)
    est = fp.nucleation_estimates(weak, weak.Delta)
    if comm.rank == 0:
        record = {**record, "Lc": lc, "estimates": est}
        _write(run.file("friction_patch.csv"), run.file("friction_patch.json"), done, record)
        _plot_patch.plot_growth(lp, g, closed, lc, est, run.file("friction_patch.png"),
                                f"friction patch in a block L = {args.length:g}"
                                + (" (reversed)" if args.reverse else ""), record)
        _cli.say(f"Lc = {lc}; estimates {est}")
    return 0 if closed.all() else 1


if __name__ == "__main__":
    _cli.run(main)
