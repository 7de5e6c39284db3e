"""Cost of the Bloch reduction ``P^H A P`` against the rest of a strip eigen-solve.

For a sequence of meshes (one wavelength at ``k``, P2, refined in both directions) prints and
writes ``strip_benchmark.csv``: unknowns, and wall times of assembly (``K, M, M_Gamma``), building
``P``, the three products ``P^H A P``, the friction rows, and the PEP solve, plus the relative
error against the check value of docs/design.md section 4 (default case only). Run serially and
under ``mpirun -n 2`` to see the scaling::

    ./run python workflows/strip_benchmark.py
    ./run mpirun -n 2 python workflows/strip_benchmark.py

``--spectrum-k K``: instead, the cost per eigenvalue of the strip's complete spectrum at ``K``
(``sweep_k.py --model strip``'s cell and box: P2, 12 cells per wavelength, ``ny = 6``,
``|Im Lambda| <= k c_d``) against the 1D model's in the same box and in the 1D sweep's region,
side by side in one run (:func:`forms.studies.strip_sweep.spectrum_cost`), written to
``strip_spectrum_cost_np<ranks>.json``::

    ./run python workflows/strip_benchmark.py --spectrum-k 4 --out workflows/results/strip_cost
"""

from __future__ import annotations

import argparse
import json
import os

import _cli

from mpi4py import MPI

from analytic.numerics.spectrum import Region
from analytic.params import Params
from forms.friction import DIRICHLET_DIAGONAL, FrictionLaw, apply_dirichlet, friction_operator
from forms.models.strip import build_strip_problem
from forms.solvers.slepc import PolynomialSolver
from forms.studies import strip_sweep
from meshes.strip import strip_mesh, wavelength

CHECK_VALUE = 0.2716852879456 - 6.5866951866228j
#: Options prefixes of the SLEPc objects (the PEP solve of every level; --spectrum-k: the
#: strip's region solve and its count's LU).
PETSC_PREFIXES = ("bench_", *strip_sweep.PREFIXES)


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    p = _cli.make_parser(__doc__, PETSC_PREFIXES)
    p.add_argument("--levels", type=int, default=4, help="mesh levels (cells double each)")
    p.add_argument("--nx0", type=int, default=16, help="cells along x on the coarsest mesh")
    p.add_argument("--ny0", type=int, default=4, help="cells along y on the coarsest mesh")
    p.add_argument("--spectrum-k", type=float, default=0.0,
                   help="> 0: the complete-spectrum cost at this k instead (see above)")
    p.add_argument("--strip-c-max", type=float, default=1.0,
                   help="--spectrum-k: box |Im Lambda| <= strip_c_max k c_d + omega0")
    p.add_argument("--omega0", type=float, default=0.0, help="--spectrum-k: see --strip-c-max")
    p.add_argument("--out", default="out/strip_benchmark", help="output directory")
    return p


def main(comm=None, argv: list[str] | None = None) -> int:
    """Run the benchmark."""
    args, comm = _cli.start(build_parser(), argv, comm)
    _cli.positive_int("--levels", args.levels, 1, 8)
    _cli.positive_int("--nx0", args.nx0, 2)
    _cli.positive_int("--ny0", args.ny0, 1)
    if not (0.0 <= args.spectrum_k <= 50.0 and args.strip_c_max > 0 and args.omega0 >= 0):
        raise _cli.ParameterError("--spectrum-k, --strip-c-max, --omega0 are outside their "
                                  "allowed ranges 0 <= k <= 50, > 0, >= 0")
    parameters = {"levels": args.levels, "nx0": args.nx0, "ny0": args.ny0,
                  "spectrum_k": args.spectrum_k, "strip_c_max": args.strip_c_max,
                  "omega0": args.omega0}
    with _cli.RunFolder(comm, args.out, "strip_benchmark", parameters,
                        outputs=("strip_benchmark_np*.csv", "strip_spectrum_cost_np*.json")):
        return _run(comm, args) if not args.spectrum_k else _spectrum_cost(comm, args)


def _spectrum_cost(comm, args: argparse.Namespace) -> int:
    params, k = Params(), args.spectrum_k
    reg = Region()  # the 1D sweep's growth-rate range
    box = strip_sweep.strip_box(params, k, reg.re_min, reg.re_max, args.strip_c_max, args.omega0)
    cost = strip_sweep.spectrum_cost(comm, params, k, box)
    if comm.rank == 0:
        path = os.path.join(args.out, f"strip_spectrum_cost_np{comm.size}.json")
        _cli.write_json(path, {"k": k, "parameters": params.as_dict(), **cost,
                               "ratio_per_eigenvalue": {
                                   name: cost["strip"]["seconds_per_eigenvalue"]
                                   / cost[name]["seconds_per_eigenvalue"]
                                   for name in ("section_same_box", "section_region")},
                               "command": _cli.command(), "versions": _cli.versions()})
        print(json.dumps({n: cost[n] for n in cost if n.startswith(("strip", "section"))},
                         indent=1))
        print(f"wrote {path}")
    return 0


def _run(comm, args: argparse.Namespace) -> int:
    params, k = Params(), 1.0
    rows = []
    header = ("dofs", "assemble", "bloch_map", "reduce", "friction_rows", "solve", "rel_error")
    if comm.rank == 0:
        print(f"ranks = {comm.size}; times in s")
        print(" ".join(f"{h:>13}" for h in header), flush=True)
    for level in range(args.levels):
        nx, ny = args.nx0 * 2**level, args.ny0 * 2**level
        strip = strip_mesh(comm, wavelength(k), params.H, nx, ny)
        comm.barrier()
        problem = build_strip_problem(strip, params, k=k, degree=2)
        t0 = MPI.Wtime()
        op = friction_operator(FrictionLaw.from_params(params), problem.stiffness, problem.mass,
                               problem.interface_mass, problem.interface_x, problem.interface_y)
        apply_dirichlet(op.matrices, list(problem.interface_y) + list(problem.dirichlet),
                        op.constant_term, DIRICHLET_DIAGONAL)
        t_rows = MPI.Wtime() - t0
        solver = PolynomialSolver(comm, nev=1, prefix="bench_")
        t0 = MPI.Wtime()
        res = solver.solve(op, CHECK_VALUE)
        t_solve = MPI.Wtime() - t0
        lam = res.pairs[0].value if res.pairs else complex("nan")
        res.destroy()
        solver.destroy()
        dofs = op.matrices[0].getSize()[0]
        op.destroy()
        tm = problem.timings
        row = (dofs, tm["assemble"], tm["bloch_map"], tm["reduce"], t_rows, t_solve,
               abs(lam - CHECK_VALUE) / abs(CHECK_VALUE))
        # slowest rank sets the wall time
        row = (row[0], *[comm.allreduce(v, op=MPI.MAX) for v in row[1:6]], row[6])
        rows.append(row)
        problem.destroy()
        if comm.rank == 0:
            print(f"{row[0]:>13d} " + " ".join(f"{v:13.3e}" for v in row[1:]), flush=True)
    if comm.rank == 0:
        path = os.path.join(args.out, f"strip_benchmark_np{comm.size}.csv")
        with _cli.atomic_open(path, "w") as f:
            f.write(",".join(header) + "\n")
            for r in rows:
                f.write(",".join(f"{v:.6g}" for v in r) + "\n")
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    _cli.run(main)
