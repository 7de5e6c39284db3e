"""Dispersion sweep: FE eigenvalues of the waveguide branches over k, under MPI.

    mpirun -n N python workflows/sweep_k.py [options]        # paper defaults, bc=velocity

The ranks are split into groups of ``--group-size`` ranks; the groups share out the k values
(round-robin) and each group solves its k values on its own communicator (cross-section model,
one mesh for the whole sweep, SLEPc PEP or NEP near the frictionless waveguide prediction of
every branch). Every finished k is written at once to ``DIR/raw/k#####.npz`` (candidates with
eigenvectors), so an interrupted sweep keeps its finished k values and ``--resume`` continues.
At the end rank 0 follows the branches through the candidates by eigenvector overlap, matches
the exact roots of ``analytic`` (when available) and writes ``spectrum.csv``,
``summary.json`` and ``dispersion.png``.

Exit codes: 0 all fine; 1 some solves failed (see ``status`` in spectrum.csv and
``failures`` in summary.json); 2 bad input (nothing written).
"""

from __future__ import annotations

import os

# One MPI rank per core: a threaded BLAS/OpenMP in every rank oversubscribes the cores. Must be
# set before numpy/PETSc load OpenBLAS and libgomp.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import csv  # noqa: E402
import json  # noqa: E402
import logging  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from typing import TYPE_CHECKING  # noqa: E402

import _cli  # noqa: E402
import numpy as np  # noqa: E402

if TYPE_CHECKING:
    from mpi4py import MPI

    from analytic.params import Params
    from forms.cross_section import CrossSectionModel
    from forms.solvers import PolynomialSolver, SplitSolver
    from forms.tracking import Branch

    Solver = PolynomialSolver | SplitSolver

#: Default k grid: shows the first maximum of the n = 0 growth rate (k H ~ 0.8 at the paper's
#: defaults) and the n = 1, 2 branches up to k H = 3.
DEFAULT_K = "0.05:6:120"
#: Relative distance within which an exact root is taken to be the FE eigenvalue's.
MATCH_RTOL = 1e-6
OUTPUT_FILES = ("spectrum.csv", "summary.json", "dispersion.png")


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (ParameterError -> exit 2 via _cli.run)."""

    def error(self, message: str) -> None:  # noqa: D102
        raise _cli.ParameterError(message)


def build_parser() -> argparse.ArgumentParser:
    """Command-line options (PETSc/SLEPc options such as ``-pep_type`` pass through)."""
    ap = _Parser(
        description="FE dispersion sweep of the waveguide branches (cross-section model).",
        epilog="PETSc/SLEPc options (single dash, e.g. -pep_type linear, "
        "-st_pc_factor_mat_solver_type superlu_dist) are passed through.",
    )
    _cli.add_param_arguments(ap)
    ap.add_argument("--k", default=DEFAULT_K, help="start:stop:count or k1,k2,... (%(default)s)")
    ap.add_argument("--branches", type=int, default=3,
                    help="waveguide branches n = 0..B-1 to follow, both partners (%(default)s)")
    ap.add_argument("--nev", type=int, default=4,
                    help="eigenvalues computed near each branch's target (%(default)s)")
    ap.add_argument("--degree", type=int, default=3, help="Lagrange degree 1..6 (%(default)s)")
    ap.add_argument("--cells", type=int, default=0,
                    help="cells of the interval mesh (0: chosen from k, H, degree)")
    ap.add_argument("--solver", choices=("pep", "nep"), default="pep",
                    help="SLEPc PEP on the polynomial form or NEP on the split form")
    ap.add_argument("--out", default=os.path.join("out", "sweep_k"), help="output directory")
    ap.add_argument("--group-size", type=int, default=1,
                    help="ranks per group (must divide the number of ranks) (%(default)s)")
    ap.add_argument("--resume", action="store_true",
                    help="continue a sweep in --out with the same settings")
    ap.add_argument("--no-plot", action="store_true", help="skip dispersion.png")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    return ap


def validate(args: argparse.Namespace, n_ranks: int) -> tuple:
    """Check every input (no side effects); raise ParameterError on the first bad one."""
    params = _cli.params_from_args(args)
    if not math.isfinite(params.H):
        raise _cli.ParameterError("H = inf: the cross-section model needs a finite H > 0")
    k = _cli.parse_k(args.k)
    _cli.positive_int("--branches", args.branches, 1, 20)
    _cli.positive_int("--nev", args.nev, 1, 50)
    _cli.positive_int("--degree", args.degree, 1, 6)
    _cli.positive_int("--cells", args.cells, 0, 100000)
    _cli.positive_int("--group-size", args.group_size, 1, n_ranks)
    if n_ranks % args.group_size:
        raise _cli.ParameterError(
            f"--group-size = {args.group_size} must divide the number of ranks ({n_ranks})"
        )
    return params, k


def run_config(args: argparse.Namespace, params: Params, k: np.ndarray, cells: int,
               ratio: float) -> dict:
    """Everything that determines the numbers (compared on --resume)."""
    return {
        "params": params.as_dict(),
        "k": [float(v) for v in k],
        "branches": args.branches,
        "nev": args.nev,
        "degree": args.degree,
        "cells": cells,
        "grading_ratio": ratio,
        "solver": args.solver,
    }


def _raw_path(out: str, index: int) -> str:
    return os.path.join(out, "raw", f"k{index:05d}.npz")


def idle_barrier(comm: MPI.Comm, poll: float = 0.02) -> None:
    """Barrier that sleeps while waiting.

    OpenMPI's blocking Barrier spins at 100% CPU, which steals a core from the ranks still
    working (e.g. rank 0's post-processing).
    """
    req = comm.Ibarrier()
    while not req.Test():
        time.sleep(poll)


def make_solver(kind: str, comm: MPI.Comm, nev: int) -> Solver:
    """A fresh PEP or NEP solver (options from the PETSc database)."""
    if kind == "pep":
        from forms.solvers import PolynomialSolver

        return PolynomialSolver(comm, nev=nev)
    from forms.solvers import SplitSolver

    return SplitSolver(comm, nev=nev)


def destroy_quietly(obj: Solver) -> None:
    """Destroy a solver that may be in an error state (a failed solve) without raising."""
    from petsc4py import PETSc

    try:
        obj.destroy()
    except PETSc.Error:
        pass


def solve_one_k(model: CrossSectionModel, solver: Solver, blist: list[Branch], p: Params,
                k: float, nev: int) -> dict:
    """Solve all branch targets at one k on the model's communicator (collective).

    Returns (meaningful on the group's rank 0): candidate values, residuals, normalized
    canonical vectors, the branch index of each candidate and SLEPc's reason per branch;
    ``"broken"`` is True if a solve raised (the caller then replaces the solver).
    """
    from forms.tracking import normalized, waveguide_lambda

    op = model.operator(k)
    vals, res, vecs, owner, reasons, nconv = [], [], [], [], [], []
    broken = False
    for j, b in enumerate(blist):
        target = waveguide_lambda(p, b, k)
        try:
            out = solver.solve(op, target, nev=nev)
        except Exception as err:  # a PETSc error in one solve must not stop the sweep
            reasons.append(f"error: {type(err).__name__}: {err}".replace("\n", " "))
            nconv.append(0)
            broken = True
            reasons.extend(["skipped: solver error at an earlier branch of this k"]
                           * (len(blist) - j - 1))
            nconv.extend([0] * (len(blist) - j - 1))
            break
        reasons.append(out.reason)
        nconv.append(out.converged)
        for pair in out.pairs[:nev]:
            v = model.canonical(pair.vector)
            if v is not None:
                vecs.append(normalized(v[:, 1:]))
                vals.append(pair.value)
                res.append(pair.residual)
                owner.append(j)
        out.destroy()
    n = model.size
    return {
        "values": np.asarray(vals, dtype=complex),
        "residuals": np.asarray(res, dtype=float),
        "vectors": np.asarray(vecs, dtype=complex).reshape(len(vals), n),
        "owner": np.asarray(owner, dtype=np.int64),
        "reasons": np.asarray(reasons, dtype=str),
        "nconv": np.asarray(nconv, dtype=np.int64),
        "broken": broken,
    }


class Repairer:
    """Re-solves a lost branch point near an extrapolated target, on one process (rank 0).

    Built lazily (only if a branch is lost) on ``MPI.COMM_SELF`` with the sweep's discretisation,
    so the repaired values do not depend on the number of ranks either.
    """

    def __init__(self, params: Params, model_kwargs: dict, solver: str, nev: int) -> None:
        self.params, self.model_kwargs, self.solver_kind, self.nev = (params, model_kwargs,
                                                                      solver, nev)
        self.model = None
        self.solver = None
        self.calls = 0

    def __call__(self, k: float, target: complex) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Candidates ``(values, normalized canonical vectors, residuals)`` near ``target``."""
        from mpi4py import MPI

        from forms.cross_section import CrossSectionModel
        from forms.tracking import normalized

        if self.model is None:
            self.model = CrossSectionModel(MPI.COMM_SELF, self.params, **self.model_kwargs)
            self.solver = make_solver(self.solver_kind, MPI.COMM_SELF, self.nev)
        self.calls += 1
        try:
            out = self.solver.solve(self.model.operator(k), target, nev=self.nev)
        except Exception:  # noqa: BLE001 - the point then stays lost
            return np.zeros(0, complex), np.zeros((0, self.model.size), complex), np.zeros(0)
        vals = np.array([p.value for p in out.pairs], dtype=complex)
        vecs = np.array([normalized(self.model.canonical(p.vector)[:, 1:]) for p in out.pairs],
                        dtype=complex).reshape(len(vals), self.model.size)
        res = np.array([p.residual for p in out.pairs], dtype=float)
        out.destroy()
        return vals, vecs, res

    def destroy(self) -> None:
        """Destroy the PETSc/SLEPc objects."""
        if self.solver is not None:
            destroy_quietly(self.solver)
            self.model.destroy()


def save_raw(out: str, index: int, k: float, seconds: float, data: dict) -> None:
    """Write one k atomically (tmp file + rename)."""
    path = _raw_path(out, index)
    tmp = os.path.join(os.path.dirname(path), "." + os.path.basename(path) + ".tmp")
    with open(tmp, "wb") as fh:
        np.savez(fh, k=k, index=index, seconds=seconds, **data)
    os.replace(tmp, path)


def load_raw(out: str, n_k: int) -> dict[int, dict]:
    """All finished k values in ``out/raw`` (index -> arrays)."""
    done = {}
    for i in range(n_k):
        path = _raw_path(out, i)
        if os.path.exists(path):
            with np.load(path) as z:
                done[i] = {key: z[key] for key in z.files}
    return done


def exact_for_branch(p: Params, b: Branch, k: np.ndarray, fe: np.ndarray
                     ) -> tuple[np.ndarray, str]:
    """Exact roots matched to the FE values of one branch (NaN where none matched).

    Uses ``analytic.branches.polish_root`` started from each FE eigenvalue; a root is accepted
    if it converged within ``MATCH_RTOL`` of the FE value. Returns (roots, note).
    """
    exact = np.full(len(k), np.nan + 1j * np.nan)
    try:
        from analytic.branches import polish_root
    except ImportError as err:
        return exact, f"no exact roots: {err}"
    for i, (kk, lam) in enumerate(zip(k, fe, strict=True)):
        if not np.isfinite(lam):
            continue
        try:
            root = polish_root(p, float(kk), complex(lam))
        except Exception:  # noqa: BLE001 - an unmatched point stays empty
            continue
        if root.converged and abs(root.value - lam) <= MATCH_RTOL * abs(root.value):
            exact[i] = root.value
    return exact, "analytic.branches.polish_root from each FE value"


def exact_lines(p: Params, blist: list[Branch], k_fine: np.ndarray
                ) -> dict[str, np.ndarray] | None:
    """Analytic branch lines for the plot (``analytic.branches.follow_branch``), or None."""
    try:
        from analytic.branches import follow_branch
    except ImportError:
        return None
    lines = {}
    for b in blist:
        try:
            r = follow_branch(p, b.n, b.sign, k_fine)
        except Exception:  # noqa: BLE001 - the plot then shows FE points only
            continue
        lam = np.where(np.asarray(r.ok), np.asarray(r.Lambda), np.nan)
        lines[b.label] = lam
    return lines


def postprocess(out: str, p: Params, k: np.ndarray, blist: list[Branch], done: dict[int, dict],
                repairer: Repairer | None = None) -> dict:
    """Track branches (repairing lost points), match exact roots, write spectrum.csv."""
    from forms.tracking import track_branch, waveguide_lambda

    order = np.argsort(k, kind="stable")
    rows, failures, lost, notes = [], [], [], set()
    per_branch = {}
    for j, b in enumerate(blist):
        vals, vecs, ress, reasons = [], [], [], []
        for i in order:
            d = done.get(int(i))
            if d is None:
                vals.append(np.array([]))
                vecs.append(np.zeros((0, 1)))
                ress.append(np.array([]))
                reasons.append("not computed")
                continue
            sel = d["owner"] == j
            vals.append(d["values"][sel])
            vecs.append(d["vectors"][sel])
            ress.append(d["residuals"][sel])
            reasons.append(str(d["reasons"][j]) if j < len(d["reasons"]) else "missing")
        ks = k[order]

        def resolve(m: int, target: complex, ress=ress, ks=ks) -> tuple[np.ndarray, np.ndarray]:
            v, w, r = repairer(float(ks[m]), target)
            ress[m] = np.concatenate([np.asarray(ress[m], dtype=float), r])
            return v, w

        tr = track_branch(vals, vecs, waveguide_lambda(p, b, float(ks[0])), k=ks,
                          resolve=resolve if repairer is not None else None)
        fe = np.full(len(order), np.nan + 1j * np.nan)
        res = np.full(len(order), np.nan)
        status = list(tr.status)
        for m, c in enumerate(tr.choice):
            if c >= 0:
                fe[m] = vals[m][c]
                res[m] = ress[m][c]
            if not reasons[m].startswith("CONVERGED") and c < 0:
                status[m] = f"failed: {reasons[m]}"
                failures.append({"k": float(k[order[m]]), "branch": b.label,
                                 "reason": reasons[m]})
            elif status[m].startswith("lost"):
                lost.append({"k": float(k[order[m]]), "branch": b.label, "reason": status[m]})
        exact, note = exact_for_branch(p, b, k[order], fe)
        notes.add(note)
        per_branch[b.label] = {"k": k[order], "fe": fe, "exact": exact}
        for m in range(len(order)):
            rows.append((float(k[order[m]]), b.label, fe[m], res[m], exact[m], status[m]))
    rows.sort(key=lambda r: (r[0], blist.index(_parse(r[1]))))

    def fmt(x: float) -> str:
        return "" if not np.isfinite(x) else repr(float(x))

    tmp = os.path.join(out, "spectrum.csv.tmp")
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["k", "branch", "re_lambda", "im_lambda", "residual",
                    "re_lambda_exact", "im_lambda_exact", "status"])
        for kk, lab, lam, r, ex, st in rows:
            w.writerow([repr(kk), lab, fmt(lam.real), fmt(lam.imag), fmt(r),
                        fmt(ex.real), fmt(ex.imag), st])
    os.replace(tmp, os.path.join(out, "spectrum.csv"))
    errs = [abs(fe - ex) / abs(ex) for bl in per_branch.values()
            for fe, ex in zip(bl["fe"], bl["exact"], strict=True)
            if np.isfinite(fe) and np.isfinite(ex)]
    best = None
    for lab, bl in per_branch.items():
        ok = np.isfinite(bl["fe"])
        if ok.any():
            i = int(np.nanargmax(np.where(ok, bl["fe"].real, -np.inf)))
            if best is None or bl["fe"][i].real > best["re_lambda"]:
                best = {"branch": lab, "k": float(bl["k"][i]), "re_lambda": float(bl["fe"][i].real),
                        "im_lambda": float(bl["fe"][i].imag)}
    return {
        "per_branch": per_branch,
        "failures": failures,
        "lost": lost,
        "exact_note": "; ".join(sorted(notes)),
        "matched_exact": len(errs),
        "max_relative_error": float(max(errs)) if errs else None,
        "most_unstable": best,
    }


def _parse(label: str) -> Branch:
    from forms.tracking import Branch

    return Branch.parse(label)


def plot(out: str, p: Params, blist: list[Branch], per_branch: dict, best: dict | None,
         meta: dict) -> None:
    """dispersion.png: growth rate and frequency against k, FE points on the exact lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kmin = min(float(np.min(bl["k"])) for bl in per_branch.values())
    kmax = max(float(np.max(bl["k"])) for bl in per_branch.values())
    k_fine = np.linspace(kmin, kmax, 400)
    lines = exact_lines(p, blist, k_fine)
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9.5, 7.5), sharex=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for b in blist:
        c = colors[b.n % len(colors)]
        bl = per_branch[b.label]
        mk = "o" if b.sign < 0 else "s"
        if lines is not None and b.label in lines:
            lam = lines[b.label]
            ax1.plot(k_fine, lam.real, "-", color=c, lw=1.0, alpha=0.7)
            ax2.plot(k_fine, lam.imag, "-", color=c, lw=1.0, alpha=0.7)
        ax1.plot(bl["k"], bl["fe"].real, mk, ms=3, mfc="none", color=c, label=f"FE {b.label}")
        ax2.plot(bl["k"], bl["fe"].imag, mk, ms=3, mfc="none", color=c)
    if lines:
        ax1.plot([], [], "-", color="0.3", lw=1.0, label="exact (analytic)")
    if best is not None:
        ax1.plot([best["k"]], [best["re_lambda"]], "*", ms=16, color="crimson",
                 label=f"most unstable:\n{best['branch']}, k = {best['k']:.3g},\n"
                 f"Re = {best['re_lambda']:.4g}")
        ax2.plot([best["k"]], [best["im_lambda"]], "*", ms=16, color="crimson")
    ax1.axhline(0.0, color="k", lw=0.6)
    ax1.set_ylabel(r"growth rate Re $\Lambda$")
    ax2.set_ylabel(r"frequency Im $\Lambda$")
    ax2.set_xlabel("k")
    ax1.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    title = (f"f={p.f:g}, gamma={p.gamma:g}, beta={p.beta:g}, Delta={p.Delta:g}, H={p.H:g}, "
             f"bc={p.bc}")
    if p.generalized:
        title += f", alpha_pc={p.alpha_pc:g}, alpha_ld={p.alpha_ld:g}"
    ax1.set_title(title + ("\nlines: exact roots (analytic)" if lines else "\n(no exact lines)"),
                  fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "dispersion.png"), dpi=130,
                metadata={"Title": "FE dispersion sweep", "Description": json.dumps(meta),
                          "Software": "workflows/sweep_k.py"})
    plt.close(fig)


def versions() -> dict[str, str]:
    """Software versions for the summary."""
    import dolfinx
    from petsc4py import PETSc
    from slepc4py import SLEPc

    v = {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "dolfinx": dolfinx.__version__,
        "petsc": ".".join(map(str, PETSc.Sys.getVersion())),
        "slepc": ".".join(map(str, SLEPc.Sys.getVersion())),
        "platform": platform.platform(),
    }
    try:
        import mpi4py

        v["mpi4py"] = mpi4py.__version__
    except ImportError:
        pass
    return v


def finish(comm: MPI.Comm, args: argparse.Namespace, out: str, params: Params, k: np.ndarray,
           blist: list[Branch], cells: int, ratio: float, form: str, settings: dict,
           todo: list, wall: float, cpu: list) -> int:
    """Rank 0: track, match, write spectrum.csv, summary.json, dispersion.png; exit code."""
    k_max = float(np.max(k))
    group_size = args.group_size
    n_groups = comm.size // group_size
    code = 0
    done = load_raw(out, len(k))
    repairer = Repairer(params, {"degree": args.degree, "cells": cells, "k_max": k_max,
                                 "n_max": args.branches - 1, "ratio": ratio,
                                 "form": form}, args.solver, args.nev)
    post = postprocess(out, params, k, blist, done, repairer)
    repairer.destroy()
    times = [float(d["seconds"]) for d in done.values()]
    summary = {
        "parameters": params.as_dict(),
        "k": {"spec": args.k, "count": len(k), "min": float(np.min(k)), "max": k_max},
        "branches": [b.label for b in blist],
        "discretisation": {"model": "cross-section (1D in y)", "degree": args.degree,
                           "cells": cells, "grading_ratio": ratio,
                           "unknowns": int(2 * (args.degree * cells + 1))},
        "solver": settings | {"form": form, "nev_per_branch": args.nev},
        "mpi": {"ranks": comm.size, "group_size": group_size, "groups": n_groups},
        "cpu_time_s_per_rank": cpu,
        "resumed": bool(args.resume),
        "computed_this_run": len(todo),
        "wall_time_s": wall,
        "per_k_time_s": {"mean": float(np.mean(times)), "min": float(np.min(times)),
                         "max": float(np.max(times)),
                         "note": "one group, all branches; 'values' in k order",
                         "values": [float(done[i]["seconds"]) if i in done else None
                                    for i in range(len(k))]}
        if times else None,
        "failures": post["failures"],
        "lost": post["lost"],
        "repair_solves": repairer.calls,
        "exact": {"source": post["exact_note"], "matched": post["matched_exact"],
                  "max_relative_error": post["max_relative_error"]},
        "most_unstable": post["most_unstable"],
        "versions": versions(),
        "command": " ".join(sys.argv),
    }
    with open(os.path.join(out, "summary.json.tmp"), "w") as fh:
        json.dump(summary, fh, indent=1)
    os.replace(os.path.join(out, "summary.json.tmp"), os.path.join(out, "summary.json"))
    if not args.no_plot:
        plot(out, params, blist, post["per_branch"], post["most_unstable"],
             {"parameters": params.as_dict(), "degree": args.degree, "cells": cells})
    if post["failures"]:
        print(f"warning: {len(post['failures'])} solve(s) failed, see {out}/summary.json",
              file=sys.stderr)
        code = 1
    if post["lost"]:
        print(f"note: branch lost at {len(post['lost'])} point(s), see {out}/summary.json",
              file=sys.stderr)
    best = post["most_unstable"]
    if best is not None:
        print(f"most unstable: branch {best['branch']} at k = {best['k']:.6g}: "
              f"Lambda = {best['re_lambda']:.10g} {best['im_lambda']:+.10g}i "
              f"({len(k)} k values, {wall:.1f} s on {comm.size} rank(s)) -> {out}")
    return code


def main(comm: MPI.Comm) -> int:  # noqa: C901 - a workflow script reads top to bottom
    """Run the sweep on ``comm`` (every rank calls this)."""
    args, extra = build_parser().parse_known_args()
    unknown = [a for a in extra if a.startswith("--")]
    if unknown:  # single-dash ones are PETSc/SLEPc options
        raise _cli.ParameterError(f"unrecognized argument {unknown[0]} (see --help)")
    params, k = validate(args, comm.size)  # every rank, before any collective or file
    from forms.cross_section import CrossSectionModel
    from forms.tracking import branches
    from meshes.interval import default_cells, grading_ratio

    blist = branches(args.branches)
    k_max = float(np.max(k))
    cells = args.cells or default_cells(k_max, params.H, args.degree, args.branches - 1,
                                        params.beta)
    ratio = grading_ratio(k_max, params.H)
    config = run_config(args, params, k, cells, ratio)
    out = args.out
    cfg_path = os.path.join(out, "raw", "config.json")
    if args.resume and os.path.exists(cfg_path):
        with open(cfg_path) as fh:
            old = json.load(fh)
        if old != json.loads(json.dumps(config)):
            diff = sorted(key for key in config if old.get(key) != json.loads(
                json.dumps(config[key])))
            raise _cli.ParameterError(
                f"--resume: {out} holds a sweep with different settings ({', '.join(diff)})"
            )
    comm.Barrier()
    t_start = time.perf_counter()
    cpu_start = time.process_time()
    if comm.rank == 0:
        os.makedirs(os.path.join(out, "raw"), exist_ok=True)
        if not args.resume:
            for name in os.listdir(os.path.join(out, "raw")):
                if name.startswith("k") and name.endswith(".npz"):
                    os.remove(os.path.join(out, "raw", name))
            for name in OUTPUT_FILES:
                if os.path.exists(os.path.join(out, name)):
                    os.remove(os.path.join(out, name))
        with open(cfg_path, "w") as fh:
            json.dump(config, fh, indent=1)
        todo = [i for i in range(len(k)) if not os.path.exists(_raw_path(out, i))]
    else:
        todo = None
    todo = comm.bcast(todo, root=0)

    group_size = args.group_size
    n_groups = comm.size // group_size
    color = comm.rank // group_size
    gcomm = comm.Split(color, comm.rank)
    mine = todo[color::n_groups]

    model = CrossSectionModel(gcomm, params, degree=args.degree, cells=cells, k_max=k_max,
                              n_max=args.branches - 1, ratio=ratio,
                              form="polynomial" if args.solver == "pep" else "split")
    solver = make_solver(args.solver, gcomm, args.nev)
    settings = solver.settings()

    bar = None
    if comm.rank == 0 and not args.quiet and mine:
        from tqdm import tqdm

        bar = tqdm(total=len(mine), desc=f"k values (group 0 of {n_groups})", unit="k",
                   file=sys.stderr)
    try:
        for i in mine:
            t0 = time.perf_counter()
            data = solve_one_k(model, solver, blist, params, float(k[i]), args.nev)
            if data.pop("broken"):
                destroy_quietly(solver)
                solver = make_solver(args.solver, gcomm, args.nev)
            seconds = time.perf_counter() - t0
            if gcomm.rank == 0:
                save_raw(out, i, float(k[i]), seconds, data)
            if bar is not None:
                bar.update(1)
    except KeyboardInterrupt:
        if bar is not None:
            bar.close()
        if comm.rank == 0:
            n_done = sum(os.path.exists(_raw_path(out, j)) for j in range(len(k)))
            print(f"\ninterrupted: {n_done} of {len(k)} k values are in {out}/raw; "
                  "run again with --resume to continue", file=sys.stderr)
        return 130
    if bar is not None:
        bar.close()
    destroy_quietly(solver)
    model_form = model.form
    model.destroy()
    gcomm.Free()
    idle_barrier(comm)
    wall = time.perf_counter() - t_start
    cpu = comm.gather(time.process_time() - cpu_start, root=0)

    code = 0
    error = None
    if comm.rank == 0:
        try:
            code = finish(comm, args, out, params, k, blist, cells, ratio, model_form, settings,
                          todo, wall, cpu)
        except Exception as err:  # noqa: BLE001 - re-raised below, after releasing the ranks
            error = err
            code = 1
    idle_barrier(comm)
    code = comm.bcast(code, root=0)
    if error is not None:
        raise error
    return code


if __name__ == "__main__":
    import slepc4py

    slepc4py.init(sys.argv)
    logging.disable(logging.INFO)  # FFCx/UFL JIT chatter
    from mpi4py import MPI

    _cli.run(lambda: main(MPI.COMM_WORLD))
