"""The sliding strip's mode at one wavenumber, chosen on a branch, ready for files and pictures.

The computation behind ``workflows/mode_shape.py``:

- :func:`branch_eigenvalue`: ``k`` and ``Lambda`` of a cross-section branch, followed from small
  ``k`` (or the most unstable ``k`` of a grid), the same on every rank;
- :func:`cross_section_near`: the cross-section mode near a given target or that eigenvalue;
- :func:`bloch_strip`: the strip mesh of whole wavelengths at ``k``;
- :func:`solve_bloch_mode`: the Bloch strip solved near a target, keeping the eigenvalue whose
  mode carries ``exp(-i k x)`` (harmonic ``m = 0``), normalised, with its metadata;
- :func:`cross_section_on_strip`: the cross-section mode ``u_hat(y) exp(-i k x)`` on the strip
  mesh instead (no strip solve);
- :func:`mode_metadata`: what the run's record says about the strip, branch and model;
- :func:`phase_snapshots`: ``Re(u exp(i Im(Lambda) t))`` over one period (for XDMF);
- :func:`gather_mode`: the Lagrange VTK grid with nodal ``u`` and ``sigma_yy``, gathered on
  rank 0 as plain arrays; :func:`phase_frames`: those fields at fractions of the period;
- :func:`interface_table`: interface stresses and slip as the columns of ``interface.csv``;
- :func:`interface_of`: those stresses and the slip for one body or two
  (:func:`forms.mode_postprocessing.interface_stresses` on the slider's side).

Two bodies (``params.two_body``, finite ``H2``): the branch comes from the exact two-body roots
(:func:`analytic.numerics.branches.follow_branch`), the strip holds both bodies
(:func:`forms.models.strip.strip_mesh_for`) and the mode shows both.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

import dolfinx.fem
import dolfinx.mesh
import dolfinx.plot
import ufl
from mpi4py import MPI

from analytic.numerics import branches as exact_branches
from analytic.numerics.tracking import Branch, waveguide_lambda
from analytic.params import Params
from forms.elasticity import sigma
from forms.mode_postprocessing import interface_stresses, normalise
from forms.models.strip import build_strip_problem, cellwise, solve_modes, strip_mesh_for
from forms.solvers.continuation import (
    CrossSectionMode,
    cross_section_mode,
    follow_fe_branch,
    most_unstable_k,
)
from meshes.interval import grading_ratio
from meshes.strip import StripMesh, wavelength

#: Columns of :func:`interface_table`.
INTERFACE_COLUMNS = ("x", "re_sxy", "im_sxy", "re_syy", "im_syy", "re_ux", "im_ux")


@dataclass
class ModeOnStrip:
    """A normalised mode on the strip mesh (:func:`forms.mode_postprocessing.normalise`).

    Attributes:
        u: The complex displacement field.
        eigenvalue: ``Lambda``.
        residual: Relative residual of the solve that produced it.
        meta: The mode's entries of the run record (source, eigenvalue, residual, timings...).
    """

    u: dolfinx.fem.Function
    eigenvalue: complex
    residual: float
    meta: dict


@dataclass
class BlochSolve:
    """Outcome of :func:`solve_bloch_mode`.

    Attributes:
        target: The shift target.
        eigenvalues: Every converged eigenvalue, nearest the target first.
        harmonics: The dominant harmonic ``m`` of each.
        reason: SLEPc's converged reason.
        mode: The first mode with ``m = 0``, or ``None`` if none converged.
    """

    target: complex
    eigenvalues: list[complex]
    harmonics: list[int | None]
    reason: object
    mode: ModeOnStrip | None


def branch_eigenvalue(comm: MPI.Comm, params: Params, branch: tuple[int, int], k: float,
                      k_scan: np.ndarray | None = None) -> tuple[float, complex]:
    """``(k, Lambda)`` of one cross-section branch, the same on every rank (rank 0's values).

    The branch is followed from small ``k`` (:func:`follow_fe_branch` from the waveguide estimate,
    :func:`analytic.numerics.tracking.waveguide_lambda`): a ``k``-wise waveguide target can land on
    another branch. Every rank solves its own copy (``MPI.COMM_SELF``), then rank 0's numbers
    are broadcast.

    Args:
        comm: Communicator of the ranks that need the result.
        params: Parameters (rigid substrate).
        branch: ``(n, sign of Im Lambda_0)`` of the waveguide branch.
        k: Wavenumber (ignored with ``k_scan``).
        k_scan: If given, the grid point of largest ``Re Lambda`` is taken instead of ``k``.

    Returns:
        ``(k, Lambda)``; ``Lambda`` is ``nan`` if the branch was not followed up to ``k``.
    """
    if params.two_body:
        return _exact_branch_eigenvalue(comm, params, branch, k, k_scan)
    b = Branch(*branch)

    def wg(kk: float) -> complex:
        return waveguide_lambda(params, b, kk)

    if k_scan is not None:
        return comm.bcast(most_unstable_k(params, wg, k_scan), root=0)
    ks = np.linspace(min(0.05, k), k, int(np.clip(k / 0.05, 2, 400)) + 1)
    return float(k), comm.bcast(complex(follow_fe_branch(params, wg, ks)[-1]), root=0)


def _exact_branch_eigenvalue(comm: MPI.Comm, params: Params, branch: tuple[int, int], k: float,
                             k_scan: np.ndarray | None) -> tuple[float, complex]:
    """:func:`branch_eigenvalue` of two bodies: the exact branch, followed on rank 0."""
    out = None
    if comm.rank == 0:
        ks = np.asarray(k_scan if k_scan is not None else [k], dtype=float)
        res = exact_branches.follow_branch(params, branch[0], branch[1], ks)
        lam = np.where(res.ok, res.Lambda, complex("nan"))
        if k_scan is None:
            out = (float(k), complex(lam[0]))
        elif np.isfinite(lam).any():
            i = int(np.nanargmax(np.where(np.isfinite(lam), lam.real, np.nan)))
            out = (float(res.k[i]), complex(lam[i]))
        else:
            out = (float(res.k[0]), complex("nan"))
    return comm.bcast(out, root=0)


def cross_section_near(params: Params, k: float, lam_branch: complex,
                       target: complex | None = None) -> CrossSectionMode | None:
    """The cross-section mode at ``k`` near ``target`` (default: ``lam_branch``).

    Returns:
        The mode, or ``None`` if there is no finite target, nothing converged, or two bodies
        (the cross-section model is the rigid substrate's).
    """
    if params.two_body:
        return None
    if target is None and not np.isfinite(lam_branch):
        return None
    return cross_section_mode(params, k, target if target is not None else lam_branch)


def bloch_strip(comm: MPI.Comm, params: Params, k: float, wavelengths: int,
                cells_per_wavelength: int, ny: int, grading: float | None = None) -> StripMesh:
    """Strip mesh of ``wavelengths`` wavelengths ``2 pi / k``: the slider, or both bodies.

    Args:
        comm: Mesh communicator.
        params: Parameters (``H`` finite).
        k: Wavenumber.
        wavelengths: Length of the cell in wavelengths.
        cells_per_wavelength: Cells along ``x`` per wavelength.
        ny: Cells along ``y`` (in each body).
        grading: Far/near-interface cell height ratio; default
            :func:`meshes.interval.grading_ratio` of ``k H`` (as for the cross-section mesh).
    """
    grading = grading if grading is not None else grading_ratio(k, params.H)
    return strip_mesh_for(comm, params, wavelengths * wavelength(k),
                          wavelengths * cells_per_wavelength, ny, grading=grading)


def solve_bloch_mode(strip: StripMesh, params: Params, k: float, degree: int, target: complex,
                     nev: int) -> BlochSolve:
    """Bloch strip at ``k`` solved near ``target``; keeps the mode carrying ``exp(-i k x)``.

    A cell of one wavelength also holds the modes of ``0, -k, 2k, ...``; the kept one is the
    nearest to the target whose dominant harmonic is ``m = 0``
    (:func:`forms.mode_postprocessing.harmonic_content`). Collective; the strip's SLEPc options
    prefix is ``strip_``. Every PETSc object is destroyed before returning.
    """
    problem = build_strip_problem(strip, params, k=k, degree=degree)
    t0 = time.perf_counter()
    modes = solve_modes(problem, target, nev=nev)
    t_solve = time.perf_counter() - t0
    try:
        wanted = [m for m in modes if m.harmonic == 0]
        found = None
        if wanted:
            best = wanted[0]
            lam = best.eigenvalue
            u = problem.to_function(best.vector, name="u")
            normalise(u)
            meta = {
                "source": "Bloch-periodic 2D strip (forms.models.strip), route (a): P^H A P"
                          + (", two bodies" if params.two_body else ""),
                "target": [target.real, target.imag], "eigenvalue": [lam.real, lam.imag],
                "residual": best.residual, "harmonic_content_m0": best.harmonics.get(0, 0.0),
                "solver": problem.last_solve,
                "other_eigenvalues": [{"re": m.eigenvalue.real, "im": m.eigenvalue.imag,
                                       "harmonic": m.harmonic, "wavenumber": k + 2 * math.pi *
                                       (m.harmonic or 0) / strip.length} for m in modes],
                "phase_velocity": lam.imag / k,
                "timings": {**problem.timings, "solve": t_solve},
            }
            found = ModeOnStrip(u, lam, best.residual, meta)
        return BlochSolve(target, [m.eigenvalue for m in modes], [m.harmonic for m in modes],
                          problem.last_solve.get("reason"), found)
    finally:
        for m in modes:
            m.vector.destroy()
        problem.destroy()


def cross_section_on_strip(strip: StripMesh, xs: CrossSectionMode, degree: int) -> ModeOnStrip:
    """The cross-section mode ``u_hat(y) exp(-i k x)`` interpolated on the strip (no solve).

    Args:
        strip: The strip mesh.
        xs: A cross-section mode (:func:`cross_section_near`).
        degree: Lagrange degree of the vector space on the strip.
    """
    V = dolfinx.fem.FunctionSpace(strip.mesh, ufl.VectorElement(
        "Lagrange", strip.mesh.ufl_cell(), degree))
    u = dolfinx.fem.Function(V, name="u")
    u.interpolate(xs.field)
    normalise(u)
    lam = xs.eigenvalue
    meta = {
        "source": "cross-section model (1D FE, P3) shown as Re(u_hat(y) exp(-i k x)),"
                  " interpolated on the strip mesh; no strip solve",
        "eigenvalue": [lam.real, lam.imag], "residual": xs.residual,
        "phase_velocity": lam.imag / xs.k, "timings": {},
    }
    return ModeOnStrip(u, lam, xs.residual, meta)


def mode_metadata(strip: StripMesh, params: Params, k: float, branch_label: str, *,
                  most_unstable: bool, wavelengths: int, degree: int,
                  xs: CrossSectionMode | None, versions: dict, command: str) -> dict:
    """The run record's entries about the strip, the branch and the cross-section model.

    Args:
        strip: The strip mesh (length, cells, grading).
        params: Parameters.
        k: Wavenumber.
        branch_label: Label of the branch (e.g. ``0-``).
        most_unstable: Whether ``k`` is the most unstable one of a grid.
        wavelengths: Length of the cell in wavelengths.
        degree: Lagrange degree.
        xs: The cross-section mode (recorded if not ``None``).
        versions: Software versions.
        command: The command line.
    """
    meta = {
        "workflow": "mode_shape", "params": params.as_dict(), "k": k, "branch": branch_label,
        "most_unstable": bool(most_unstable), "length": strip.length,
        "wavelengths": wavelengths, "cells": [strip.nx, strip.ny], "grading": strip.grading,
        "degree": degree, "ranks": strip.comm.size, "versions": versions, "command": command,
    }
    if xs is not None:
        meta["cross_section"] = {"eigenvalue": [xs.eigenvalue.real, xs.eigenvalue.imag],
                                 "residual": xs.residual, "degree": 3}
    return meta


def phase_snapshots(u: dolfinx.fem.Function, lam: complex, phases: int
                    ) -> Iterator[tuple[float, dolfinx.fem.Function]]:
    """``(t, Re(u exp(i Im(Lambda) t)))`` at ``phases`` times over one period ``2 pi/|Im L|``.

    Growth is factored out; the period is 1 if ``Im Lambda = 0``. The yielded function is one
    object overwritten at every step (write it before taking the next).
    """
    u_phase = dolfinx.fem.Function(u.function_space, name="u")
    period = 2 * math.pi / abs(lam.imag) if lam.imag != 0 else 1.0
    for j in range(phases):
        t = period * j / phases
        u_phase.x.array[:] = (u.x.array * np.exp(1j * lam.imag * t)).real
        yield t, u_phase


def stress_coefficients(u: dolfinx.fem.Function, params: Params) -> tuple:
    """``(lambda, mu)`` for :func:`forms.elasticity.sigma` on ``u``'s mesh.

    Numbers (one body) or cell-wise values (two bodies: the substrate is the cells below
    ``y = 0``).
    """
    if not params.two_body:
        return params.lame_lambda, 1.0
    msh = u.function_space.mesh
    cmap = msh.topology.index_map(msh.topology.dim)
    cells = np.arange(cmap.size_local + cmap.num_ghosts, dtype=np.int32)
    mid = dolfinx.mesh.compute_midpoints(msh, msh.topology.dim, cells)
    return cellwise(msh, cells[mid[:, 1] < 0], ((params.lame_lambda,
                                                 params.substrate.lame_lambda),
                                                (1.0, params.mu2)))


def interface_of(u: dolfinx.fem.Function, params: Params) -> dict[str, np.ndarray]:
    """Interface stresses and slip (:func:`forms.mode_postprocessing.interface_stresses` keys).

    Two bodies: the stresses of the slider's side (``sxy``, ``syy`` are continuous across
    ``y = 0``; the model ties them weakly) and the slip ``u_x1 - u_x2`` in ``ux``. Collective.
    """
    if not params.two_body:
        return interface_stresses(u, params.lame_lambda, params.H)
    msh = u.function_space.mesh
    lmbda, mu = stress_coefficients(u, params)
    degree = u.function_space.ufl_element().degree()
    W = dolfinx.fem.FunctionSpace(msh, ufl.VectorElement("DG", msh.ufl_cell(), degree - 1))
    s = sigma(u, lmbda, mu)
    t = dolfinx.fem.Function(W)
    t.interpolate(dolfinx.fem.Expression(ufl.as_vector([s[0, 1], s[1, 1]]),
                                         W.element.interpolation_points()))
    tol = 1e-10 * max(params.H, params.H2)
    st = _side_values(t, tol)
    sl = _side_values(u, tol)
    return {"x": st[1][:, 0].real, "sxy": st[1][:, 1], "syy": st[1][:, 2],
            "x_slip": sl[1][:, 0].real, "ux": sl[1][:, 1] - sl[2][:, 1],
            "uy": sl[1][:, 2]}


def _side_values(f: dolfinx.fem.Function, tol: float) -> dict[int, np.ndarray]:
    """Per body (1: cells above ``y = 0``, 2: below) ``f``'s dofs on ``y = 0``.

    Rows ``(x, values...)`` gathered on every rank, averaged per ``x``, sorted by ``x``.
    """
    W = f.function_space
    msh = W.mesh
    n = W.dofmap.index_map.size_local
    bs = W.dofmap.index_map_bs
    side = dolfinx.fem.Function(W)
    cmap = msh.topology.index_map(msh.topology.dim)
    cells = np.arange(cmap.size_local + cmap.num_ghosts, dtype=np.int32)
    mid = dolfinx.mesh.compute_midpoints(msh, msh.topology.dim, cells)
    side.interpolate(lambda x: np.ones((bs, x.shape[1])), cells=cells[mid[:, 1] > 0])
    above = side.x.array.reshape(-1, bs)[:n, 0].real > 0.5
    xw = W.tabulate_dof_coordinates()[:n]
    vals = f.x.array[: bs * n].reshape(n, bs)
    out = {}
    for body, sel in ((1, above), (2, ~above)):
        on = np.flatnonzero((np.abs(xw[:, 1]) < tol) & sel)
        rows = np.vstack(msh.comm.allgather(np.column_stack([xw[on, 0], vals[on]])
                                            .astype(complex)))
        xs, inverse = np.unique(np.round(rows[:, 0].real, 12), return_inverse=True)
        counts = np.bincount(inverse, minlength=len(xs))
        cols = [xs.astype(complex)] + [
            (np.bincount(inverse, rows[:, c].real, len(xs))
             + 1j * np.bincount(inverse, rows[:, c].imag, len(xs))) / counts
            for c in range(1, rows.shape[1])]
        out[body] = np.column_stack(cols)
    return out


def gather_mode(u: dolfinx.fem.Function, lame_lambda: float, mu: float = 1.0) -> dict | None:
    """The Lagrange VTK grid of ``u``'s space with nodal ``u`` and ``sigma_yy``, on rank 0.

    ``sigma_yy`` is interpolated into Lagrange of the degree of ``u``; ``lame_lambda`` and ``mu``
    may be cell-wise (:func:`stress_coefficients`). Collective.

    Returns:
        On rank 0 ``{"cells": VTK connectivity (counts and point ids, flat), "cell_types",
        "points": (n, 3), "point_data": {"u_re", "u_im": (n, 3), "syy_re", "syy_im": (n,)}}``;
        ``None`` on the other ranks.
    """
    V = u.function_space
    msh = V.mesh
    S = dolfinx.fem.FunctionSpace(msh, ("Lagrange", V.ufl_element().degree()))
    syy = dolfinx.fem.Function(S)
    syy.interpolate(dolfinx.fem.Expression(sigma(u, lame_lambda, mu)[1, 1],
                                           S.element.interpolation_points()))
    nodal = u.x.array.reshape(-1, 2)
    zeros = np.zeros((nodal.shape[0], 1))
    arrays = {"u_re": np.hstack([nodal.real, zeros]), "u_im": np.hstack([nodal.imag, zeros]),
              "syy_re": syy.x.array.real.copy(), "syy_im": syy.x.array.imag.copy()}
    topology, cell_types, x = dolfinx.plot.create_vtk_mesh(V)
    cells = topology.reshape(-1, topology[0] + 1)
    parts = msh.comm.gather((cells, cell_types, x, arrays), root=0)
    if msh.comm.rank != 0:
        return None
    all_cells, offset = [], 0
    for c, _, xx, _ in parts:
        c = c.copy()
        c[:, 1:] += offset
        all_cells.append(c)
        offset += xx.shape[0]
    return {"cells": np.vstack(all_cells).ravel(),
            "cell_types": np.concatenate([p[1] for p in parts]),
            "points": np.vstack([p[2] for p in parts]),
            "point_data": {name: np.concatenate([p[3][name] for p in parts]) for name in arrays}}


def phase_frames(point_data: dict[str, np.ndarray], omega: float, fractions: Sequence[float]
                 ) -> list[tuple[np.ndarray, np.ndarray]]:
    """``Re(u exp(i omega t))`` and ``Re(sigma_yy exp(i omega t))`` at ``t = fraction * T``.

    ``T = 2 pi / |omega|``; growth factored out (at ``omega = 0`` the angle is
    ``2 pi fraction``).

    Args:
        point_data: ``u_re``, ``u_im`` (``(n, 3)``), ``syy_re``, ``syy_im`` (:func:`gather_mode`).
        omega: ``Im Lambda``.
        fractions: Fractions of the period.

    Returns:
        Per fraction ``(u (n, 3), sigma_yy (n,))``, real.
    """
    syy = point_data["syy_re"] + 1j * point_data["syy_im"]
    frames = []
    for frac in fractions:
        angle = math.copysign(2 * math.pi * frac, omega)
        u = np.cos(angle) * point_data["u_re"] - np.sin(angle) * point_data["u_im"]
        frames.append((u, (np.exp(1j * angle) * syy).real))
    return frames


def interface_table(data: dict[str, np.ndarray]) -> np.ndarray:
    """Columns :data:`INTERFACE_COLUMNS` from :func:`forms.mode_postprocessing.interface_stresses`.

    The slip, known at the displacement nodes, is interpolated linearly to the stress points.

    Returns:
        ``(n, 7)`` real array, one row per stress point along the interface.
    """
    ux = np.interp(data["x"], data["x_slip"], data["ux"].real) + 1j * np.interp(
        data["x"], data["x_slip"], data["ux"].imag)
    return np.column_stack([data["x"], data["sxy"].real, data["sxy"].imag, data["syy"].real,
                            data["syy"].imag, ux.real, ux.imag])
