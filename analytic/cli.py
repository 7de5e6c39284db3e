"""Command line of the ``analytic`` package, and the parameter plumbing shared with workflows.

``python -m analytic branch --k 0.5,1,2 --H 0.5 --bc velocity --branches 2`` prints CSV
``k,branch,re_lambda,im_lambda,residual,flag`` for branches ``0+, 0-, 1+, 1-, ...`` followed in
k from their cut-offs; ``flag`` is empty for a trusted root, else why not (``lost``,
``ambiguous``, ...), and any flagged row makes the exit code 1 (with a warning on stderr).
``python -m analytic units ...`` converts physical data. ``python -m analytic dispersion --out
DIR`` writes the analytic dispersion curve (CSV, JSON, PNG). Bad input: one line on stderr
naming the parameter, exit code 2. Under ``mpirun`` every rank computes the same thing and only
rank 0 prints or writes.
``python -m analytic gr --mu2 2 --rho2 1 --beta 0.5`` prints the generalized Rayleigh wave of two
half-spaces as JSON ``{"exists": ..., "speed": c/c_s1 or null}``; ``python -m analytic grmap
--out DIR`` maps where it exists over ``(mu2, rho2)``.

:func:`add_param_arguments`, :func:`params_from_args`, :func:`parse_k`, :func:`positive_int`
are also used by ``workflows/_cli.py`` (which re-exports them).
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import math
import os
import re
import sys
from collections.abc import Sequence

import numpy as np

from analytic.params import ParameterError, Params, check_k

EXIT_USAGE = 2
EXIT_FLAGGED = 1


def rank() -> int:
    """This process's rank in MPI_COMM_WORLD, also before or without ``MPI_Init``.

    From mpi4py if it is imported and initialised (this module never imports it), else from
    mpirun's environment; 0 without mpirun.
    """
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and not mpi.Is_finalized():
        return mpi.COMM_WORLD.rank
    for var in ("OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"):
        if var in os.environ:
            return int(os.environ[var])
    return 0


def world_size() -> int:
    """Number of ranks of the job (1 when not under mpirun); see :func:`rank`."""
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and not mpi.Is_finalized():
        return mpi.COMM_WORLD.size
    for var in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE"):
        if var in os.environ:
            return int(os.environ[var])
    return 1


_VERSIONS: dict[str, str] = {}
_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def blas_libraries() -> str:
    """The BLAS/LAPACK libraries this process has loaded (numpy's), e.g. OpenBLAS or the reference.

    Read from ``/proc/self/maps`` after importing numpy's linear algebra: the libraries the
    dynamic linker actually chose (Debian's alternatives, or ``LD_LIBRARY_PATH``), which set
    the speed of every dense factorisation (numpy, scipy, MUMPS) but not the results beyond
    rounding. ``"unknown"`` where ``/proc`` is not readable.
    """
    import numpy.linalg  # noqa: F401  (loads the BLAS/LAPACK libraries)

    try:
        with open("/proc/self/maps") as fh:
            paths = {line.split()[-1] for line in fh if "/" in line}
    except OSError:
        return "unknown"
    libs = sorted({os.path.realpath(p) for p in paths
                   if re.search(r"/lib(open)?blas[^/]*\.so|/liblapack[^/]*\.so", p)})
    return ", ".join(libs) if libs else "unknown"


def versions() -> dict[str, str]:
    """Versions of Python, the numerical stack, the project (git) and the machine (cached).

    Read from the installed package metadata, so it imports nothing heavy; PETSc/SLEPc library
    versions are added once petsc4py/slepc4py are initialised. The one provenance record of
    the project (JSON files, PNG text chunks).
    """
    if not _VERSIONS:
        import platform
        import subprocess
        from importlib import metadata

        out = {"python": platform.python_version()}
        for dist, key in (("numpy", "numpy"), ("scipy", "scipy"), ("matplotlib", "matplotlib"),
                          ("fenics-dolfinx", "dolfinx"), ("fenics-ffcx", "ffcx"),
                          ("petsc4py", "petsc4py"), ("slepc4py", "slepc4py"),
                          ("mpi4py", "mpi4py"), ("pyvista", "pyvista")):
            with contextlib.suppress(metadata.PackageNotFoundError):
                out[key] = metadata.version(dist)
        try:
            out["git"] = subprocess.run(["git", "-C", _ROOT, "rev-parse", "--short", "HEAD"],
                                        capture_output=True, text=True,
                                        timeout=10).stdout.strip() or "unknown"
        except (OSError, subprocess.SubprocessError):
            out["git"] = "unknown"
        out["machine"] = f"{platform.platform()}, {os.cpu_count()} cores"
        out["blas"] = blas_libraries()
        _VERSIONS.update(out)
    if "petsc4py.PETSc" in sys.modules and "petsc" not in _VERSIONS:
        from petsc4py import PETSc

        _VERSIONS["petsc"] = ".".join(map(str, PETSc.Sys.getVersion()))
    if "slepc4py.SLEPc" in sys.modules and "slepc" not in _VERSIONS:
        from slepc4py import SLEPc

        _VERSIONS["slepc"] = ".".join(map(str, SLEPc.Sys.getVersion()))
    return dict(_VERSIONS)


def json_safe(obj: object) -> object:
    """``obj`` with every non-finite float replaced: NaN -> ``None``, +-inf -> ``"inf"``/``"-inf"``.

    The project's JSON convention (strict JSON that any parser reads; docs/workflows.md).
    Dicts, lists, tuples and numpy arrays/scalars are walked; a complex number or anything
    else JSON cannot hold becomes its ``str``.
    """
    if obj is None or isinstance(obj, (bool, int, str)):
        return obj
    if isinstance(obj, float):
        if math.isnan(obj):
            return None
        if math.isinf(obj):
            return "inf" if obj > 0 else "-inf"
        return obj
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    tolist = getattr(obj, "tolist", None)  # numpy arrays and scalars
    if callable(tolist):
        return json_safe(tolist())
    if isinstance(obj, complex):
        return str(obj)
    try:
        return json_safe(float(obj))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return str(obj)


def dumps(obj: object, **kwargs: object) -> str:
    """Strict JSON of ``obj`` (:func:`json_safe`; ``allow_nan=False`` as a guard)."""
    return json.dumps(json_safe(obj), allow_nan=False, **kwargs)  # type: ignore[arg-type]


def _is_number(token: str) -> bool:
    try:
        complex(token.replace("i", "j"))
    except ValueError:
        return False
    return True


def attach_negative_values(argv: Sequence[str]) -> list[str]:
    """``--opt -1e6`` -> ``--opt=-1e6`` (argparse would read ``-1e6`` as an option)."""
    out: list[str] = []
    for tok in argv:
        if (out and tok.startswith("-") and _is_number(tok) and out[-1].startswith("--")
                and "=" not in out[-1]):
            out[-1] = f"{out[-1]}={tok}"
        else:
            out.append(tok)
    return out


def add_param_arguments(parser: argparse.ArgumentParser, defaults: Params | None = None) -> None:
    """Add the physical parameters to ``parser``.

    ``--f --gamma --beta --Delta --H --bc --alpha-pc --alpha-ld`` and the substrate's
    ``--mu2 --rho2 --beta2 --H2 --bc2`` (default ``--mu2 inf``: rigid).
    """
    d = defaults or Params()
    g = parser.add_argument_group("physical parameters (dimensionless, docs/design.md section 2)")
    g.add_argument("--f", type=float, default=d.f, help="friction coefficient f >= 0 (%(default)s)")
    g.add_argument("--gamma", type=float, default=d.gamma,
                   help="gamma = mu/(c_s sigma0 d_v f) > 0 (%(default)s)")
    g.add_argument("--beta", type=float, default=d.beta,
                   help="beta = c_s/c_d in (0, 1/sqrt 2) (%(default)s)")
    g.add_argument("--Delta", type=float, default=d.Delta,
                   help="Delta = d_v f_ss / d_v f (%(default)s)")
    g.add_argument("--H", type=float, default=d.H, help="strip height H > 0 (%(default)s)")
    g.add_argument("--bc", choices=("velocity", "stress"), default=d.bc,
                   help="top condition (%(default)s)")
    g.add_argument("--alpha-pc", type=float, default=d.alpha_pc,
                   help="Prakash-Clifton alpha_PC >= 0 (%(default)s)")
    g.add_argument("--alpha-ld", type=float, default=d.alpha_ld,
                   help="Linker-Dieterich alpha_LD >= 0 (%(default)s)")
    s = parser.add_argument_group("substrate (body 2, -H2 < y < 0; units of body 1)")
    s.add_argument("--mu2", type=float, default=d.mu2,
                   help="shear modulus mu2/mu1 > 0; inf: rigid substrate (%(default)s)")
    s.add_argument("--rho2", type=float, default=d.rho2,
                   help="density rho2/rho1 > 0 (%(default)s)")
    s.add_argument("--beta2", type=float, default=d.beta2,
                   help="beta2 = c_s2/c_d2 in (0, 1/sqrt 2); default: equal to --beta")
    s.add_argument("--H2", type=float, default=d.H2,
                   help="substrate height H2 > 0; inf: half-space (%(default)s)")
    s.add_argument("--bc2", choices=("velocity", "stress"), default=d.bc2,
                   help="bottom condition at y = -H2 (%(default)s)")


def params_from_args(args: argparse.Namespace) -> Params:
    """Build (and validate) :class:`Params` from parsed arguments."""
    d = Params()
    return Params(f=args.f, gamma=args.gamma, beta=args.beta, Delta=args.Delta, H=args.H,
                  bc=args.bc, alpha_pc=args.alpha_pc, alpha_ld=args.alpha_ld,
                  mu2=getattr(args, "mu2", d.mu2), rho2=getattr(args, "rho2", d.rho2),
                  beta2=getattr(args, "beta2", d.beta2), H2=getattr(args, "H2", d.H2),
                  bc2=getattr(args, "bc2", d.bc2))


def parse_k(spec: str, name: str = "--k") -> np.ndarray:
    """Parse ``start:stop:count`` (inclusive, linear) or ``k1,k2,...`` (as given).

    Callers merge duplicates with ``np.unique``.

    Raises:
        ParameterError: On malformed input or a non-positive / non-finite value.
    """
    s = spec.strip()
    malformed = ParameterError(
        f"{name} = {spec!r} is neither 'start:stop:count' nor a comma list of numbers")
    if ":" in s:
        parts = s.split(":")
        if len(parts) != 3:
            raise malformed
        try:
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise malformed from None
        if count < 1:
            raise ParameterError(f"{name} = {spec!r}: count must be >= 1")
        if count > 1 and not stop > start:
            raise ParameterError(f"{name} = {spec!r}: stop = {parts[1]} must be larger than "
                                 f"start = {parts[0]}")
        values = np.linspace(start, stop, count)
    else:
        items = s.split(",")
        if any(not v.strip() for v in items):
            raise ParameterError(f"{name} = {spec!r} has an empty item (two commas, or a comma "
                                 "at an end): give k1,k2,... with a number between commas")
        try:
            values = np.array([float(v) for v in items])
        except ValueError:
            raise malformed from None
    return check_k(values, name=name.lstrip("-"))


def positive_int(name: str, value: int, minimum: int = 1, maximum: int | None = None) -> int:
    """Check an integer option; raise :class:`ParameterError` naming it otherwise."""
    if value < minimum or (maximum is not None and value > maximum):
        rng = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
        raise ParameterError(f"{name} = {value} is outside its allowed range {rng}")
    return value


class OneLineParser(argparse.ArgumentParser):
    """argparse whose usage errors are a :class:`ParameterError` (one line, exit 2).

    Prefix abbreviations of long options (``--be`` for ``--beta``) are not accepted.
    """

    def __init__(self, *args, **kwargs) -> None:  # noqa: ANN002, ANN003
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> None:  # noqa: D102 - argparse hook
        raise ParameterError(message)


#: Limits of ``branch`` / ``dispersion`` (branches followed in k from their cut-offs), measured
#: on this project's 2-core machine with one branch index: k*H = 20 took 8 s, 50 took 24 s, 100
#: took 42 s (about 0.42 s per unit of k*H: the continuation's steps scale with k*H);
#: beta = 0.1 took 5 s, 0.02 took 12 s, 0.005 more than 60 s.
BRANCH_KH_MAX = 50.0
BRANCH_BETA_MIN = 0.02


def _finite_params(args: argparse.Namespace) -> Params:
    p = params_from_args(args)
    if not math.isfinite(p.H):
        raise ParameterError("H = inf: branches start at finite-H cut-offs; give a finite H > 0")
    if p.beta < BRANCH_BETA_MIN:
        raise ParameterError(f"beta = {p.beta:g} is below {BRANCH_BETA_MIN:g}, the smallest for "
                             "which the branches are followed in bounded time (the dilatational "
                             "cut-offs crowd as beta -> 0)")
    return p


def _check_branch_cost(p: Params, k: np.ndarray, branches: int) -> None:
    """Refuse k*H above :data:`BRANCH_KH_MAX`; print an estimate for a run over 10 s."""
    kh = float(np.max(k)) * p.H
    if kh > BRANCH_KH_MAX:
        raise ParameterError(f"k*H = {kh:g} is above {BRANCH_KH_MAX:g}: each branch is followed "
                             "from its cut-off with steps that scale with k*H (about 0.4 s per "
                             f"unit); use k <= {BRANCH_KH_MAX / p.H:g} or a smaller H")
    seconds = branches * (3.0 + 0.42 * kh)
    if seconds > 10 and rank() == 0:
        print(f"following {2 * branches} branches up to k*H = {kh:g}: about {seconds:.0f} s",
              file=sys.stderr, flush=True)


def _branch(args: argparse.Namespace) -> int:
    from analytic.numerics.branches import follow_branches

    p = _finite_params(args)
    k = parse_k(args.k)
    positive_int("--branches", args.branches, 1, 50)
    _check_branch_cost(p, k, args.branches)
    results = follow_branches(p, args.branches, k)
    w = csv.writer(sys.stdout, lineterminator="\n")
    w.writerow(["k", "branch", "re_lambda", "im_lambda", "residual", "flag"])
    kk = results[0].k
    flagged = 0
    for i, kv in enumerate(kk):
        for r in results:
            L = r.Lambda[i]
            flag = r.flag[i] if i < len(r.flag) else ""
            if not flag and not (r.ok[i] and np.isfinite(L)):
                flag = "not converged" if np.isfinite(L) else "lost"
            flagged += bool(flag)
            w.writerow([f"{kv:.12g}", r.label, f"{L.real:.16g}", f"{L.imag:.16g}",
                        f"{r.residual[i]:.3e}", flag])
    sys.stdout.flush()
    for r in results:
        if r.note:
            print(f"note: {r.note}", file=sys.stderr)
    if flagged:
        print(f"warning: {flagged} of {len(kk) * len(results)} rows flagged (not trusted: see"
              " the flag column); exit code 1", file=sys.stderr, flush=True)
        return EXIT_FLAGGED
    return 0


def _units(args: argparse.Namespace) -> int:
    from analytic.units import Physical, Substrate, to_dimensionless

    phys = Physical(mu=args.mu, nu=args.nu, rho=args.rho, sigma0=args.sigma0, v0=args.v0,
                    D=args.D, f=args.f, a=args.a, b=args.b, H=args.H_m)
    given = [v is not None for v in (args.mu_sub, args.nu_sub, args.rho_sub)]
    if any(given) and not all(given):
        raise ParameterError("--mu-sub, --nu-sub, --rho-sub: give all three (deformable "
                             "substrate) or none (rigid)")
    sub = None
    if all(given):
        sub = Substrate(mu=args.mu_sub, nu=args.nu_sub, rho=args.rho_sub, H=args.H_sub_m,
                        bc=args.bc2)
    c = to_dimensionless(phys, substrate=sub)
    out = {
        "physical": phys.as_dict(),
        "substrate": None if sub is None else sub.as_dict(),
        "dimensionless": c.params.as_dict(),
        "Gamma": c.params.Gamma,
        "units": {"t0_s": c.t0, "length_m": c.length, "c_s_m_per_s": c.c_s,
                  "c_d_m_per_s": c.c_d},
    }
    print(dumps(out, indent=2))
    return 0


def _dispersion(args: argparse.Namespace) -> int:
    from analytic.writers import write_dispersion

    p = _finite_params(args)
    k = parse_k(args.k)
    positive_int("--branches", args.branches, 1, 20)
    _check_branch_cost(p, k, args.branches)
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise ParameterError(f"--out = {args.out!r} exists and is not a directory")
    if rank() != 0:
        return 0  # every rank checked the input; rank 0 writes
    files = write_dispersion(p, k, args.branches, args.out)
    for f in files:
        print(f)
    return 0


def _gr(args: argparse.Namespace) -> int:
    from analytic.physics.twobody import generalized_rayleigh

    with np.errstate(all="ignore"):  # mu2 = 1e-300 is answered right, with overflow warnings
        g = generalized_rayleigh(args.mu2, args.rho2, args.beta, args.beta2)
    print(dumps(g.as_dict()))
    return 0


def _grmap(args: argparse.Namespace) -> int:
    from analytic.writers import write_gr_map

    Params(beta=args.beta, beta2=args.beta2)  # validates
    positive_int("--n", args.n, 3, 1000)
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise ParameterError(f"--out = {args.out!r} exists and is not a directory")
    for f in write_gr_map(args.out, args.beta, args.beta2, n=args.n):
        print(f)
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The ``python -m analytic`` argument parser."""
    from analytic.units import PMMA_ON_STEEL as X

    ap = OneLineParser(prog="python -m analytic", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    b = sub.add_parser("branch", help="exact roots on branches followed from the cut-offs")
    b.add_argument("--k", required=True, help="wavenumbers: 'k1,k2,...' or 'start:stop:count'")
    b.add_argument("--branches", type=int, default=1,
                   help="number of cut-off indices n (each gives n+ and n-) (%(default)s)")
    add_param_arguments(b)
    b.set_defaults(func=_branch)

    d = sub.add_parser("dispersion", help="analytic dispersion curves: CSV + JSON + PNG")
    d.add_argument("--out", required=True, help="output directory (created)")
    d.add_argument("--k", default="0.02:12:300", help="wavenumbers (%(default)s)")
    d.add_argument("--branches", type=int, default=2, help="cut-off indices n (%(default)s)")
    add_param_arguments(d)
    d.set_defaults(func=_dispersion)

    gr = sub.add_parser("gr", help="generalized Rayleigh wave of two half-spaces (JSON)")
    gr.add_argument("--mu2", type=float, required=True, help="mu2/mu1 > 0")
    gr.add_argument("--rho2", type=float, default=1.0, help="rho2/rho1 > 0 (%(default)s)")
    gr.add_argument("--beta", type=float, default=0.5, help="body 1 c_s/c_d (%(default)s)")
    gr.add_argument("--beta2", type=float, default=None, help="body 2 c_s/c_d (default: --beta)")
    gr.set_defaults(func=_gr)

    gm = sub.add_parser("grmap", help="where the generalized Rayleigh wave exists: CSV/JSON/PNG")
    gm.add_argument("--out", required=True, help="output directory (created)")
    gm.add_argument("--beta", type=float, default=0.5, help="body 1 c_s/c_d (%(default)s)")
    gm.add_argument("--beta2", type=float, default=None, help="body 2 c_s/c_d (default: --beta)")
    gm.add_argument("--n", type=int, default=121, help="grid points per axis (%(default)s)")
    gm.set_defaults(func=_grmap)

    u = sub.add_parser("units", help="physical data (SI) -> dimensionless parameters and units")
    u.add_argument("--mu", type=float, default=X.mu, help="shear modulus [Pa] (%(default)s)")
    u.add_argument("--nu", type=float, default=X.nu, help="Poisson ratio (%(default)s)")
    u.add_argument("--rho", type=float, default=X.rho, help="density [kg/m^3] (%(default)s)")
    u.add_argument("--sigma0", type=float, default=X.sigma0,
                   help="normal stress [Pa] (%(default)s)")
    u.add_argument("--v0", type=float, default=X.v0, help="sliding velocity [m/s] (%(default)s)")
    u.add_argument("--D", type=float, default=X.D, help="memory length [m] (%(default)s)")
    u.add_argument("--f", type=float, default=X.f, help="friction coefficient (%(default)s)")
    u.add_argument("--a", type=float, default=X.a, help="df/dln v (%(default)s)")
    u.add_argument("--b", type=float, default=X.b, help="df/dln phi (%(default)s)")
    u.add_argument("--H-m", type=float, default=X.H, help="height [m] (%(default)s)")
    u.add_argument("--mu-sub", type=float, default=None,
                   help="substrate shear modulus [Pa] (default: rigid substrate)")
    u.add_argument("--nu-sub", type=float, default=None, help="substrate Poisson ratio")
    u.add_argument("--rho-sub", type=float, default=None, help="substrate density [kg/m^3]")
    u.add_argument("--H-sub-m", type=float, default=math.inf,
                   help="substrate height [m] (%(default)s: half-space)")
    u.add_argument("--bc2", choices=("velocity", "stress"), default="velocity",
                   help="substrate bottom condition (%(default)s)")
    u.set_defaults(func=_units)
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: returns the exit code (2 on bad input, one line on stderr; 1 if flagged)."""
    quiet = rank() != 0
    try:
        with open(os.devnull, "w") as null, contextlib.redirect_stdout(null if quiet else
                                                                           sys.stdout), \
                contextlib.redirect_stderr(null if quiet else sys.stderr):
            args = build_parser().parse_args(
                attach_negative_values(sys.argv[1:] if argv is None else argv))
            return int(args.func(args) or 0)
    except ParameterError as err:
        if not quiet:
            print(f"error: {err}", file=sys.stderr, flush=True)
        return EXIT_USAGE
