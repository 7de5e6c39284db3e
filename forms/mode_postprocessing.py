"""Post-processing of a computed mode on the 2D strip mesh.

Works on a displacement field ``u`` (a :class:`dolfinx.fem.Function` on a vector Lagrange space
of a :mod:`meshes.strip` mesh), whatever produced it: a strip eigenvector
(:meth:`forms.models.strip.StripProblem.to_function`) or the cross-section mode interpolated on the
strip (:meth:`forms.solvers.continuation.CrossSectionMode.field`).

- :func:`harmonic_content`: share of ``|u|^2`` in each wavenumber ``k + 2 pi m / L`` of a
  Bloch cell (tells the wanted mode from the ``0, -k, 2k, ...`` modes the cell also holds);
- :func:`normalise`: largest nodal ``|u|`` equal to 1, slip real at the origin;
- :func:`interface_stresses`: ``sigma_xy``, ``sigma_yy`` and the slip along ``y = 0``.

All are collective and return the same data on every rank.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

import dolfinx.fem
import ufl
from mpi4py import MPI

from forms.elasticity import sigma

if TYPE_CHECKING:
    from forms.models.strip import StripProblem


def _allgather_rows(comm: MPI.Comm, rows: np.ndarray) -> np.ndarray:
    return np.vstack(comm.allgather(rows))


def harmonic_content(problem: StripProblem, u: dolfinx.fem.Function, m_max: int | None = None
                     ) -> dict[int, float]:
    """Share of ``|u|^2`` carried by each wavenumber ``k + 2 pi m / L`` (``|m| <= m_max``).

    A Bloch cell of one wavelength also holds the modes of ``0, -k, 2k, ...`` (``m = -1, -2,
    1``); this tells them apart. Along every line ``y = const`` the dofs of the structured strip
    sit on a uniform grid in ``x`` (right edge excluded), where the discrete Fourier sums are
    orthogonal. Collective; the same dict on every rank.

    Args:
        problem: A Bloch problem (``problem.k`` set).
        u: A full field on ``problem.V``.
        m_max: Largest ``|m|``; default: all that a line of ``degree * nx`` points resolves.

    Returns:
        ``{m: fraction}``, fractions summing to at most 1.
    """
    if problem.k is None:
        raise ValueError("harmonic content needs a Bloch cell (k set)")
    strip, V = problem.strip, problem.V
    n_owned = V.dofmap.index_map.size_local
    bs = V.dofmap.index_map_bs
    x = V.tabulate_dof_coordinates()[:n_owned]
    keep = np.abs(x[:, 0] - strip.length) > 1e-10 * strip.length
    vals = u.x.array[: bs * n_owned].reshape(n_owned, bs)[keep]
    rows = np.column_stack([x[keep, 0], x[keep, 1], vals]).astype(complex)
    rows = _allgather_rows(problem.comm, rows)
    if m_max is None:
        m_max = max(1, (V.ufl_element().degree() * strip.nx - 1) // 2)
    xs, ys, vals = rows[:, 0].real, rows[:, 1].real, rows[:, 2:]
    keys = np.round(ys / strip.height, 9)
    total = float(np.sum(np.abs(vals) ** 2))
    content = {}
    for m in range(-m_max, m_max + 1):
        q = problem.k + 2.0 * np.pi * m / strip.length
        energy = 0.0
        for key in np.unique(keys):
            on = keys == key
            coef = (vals[on] * np.exp(1j * q * xs[on])[:, None]).sum(axis=0) / on.sum()
            energy += on.sum() * float(np.sum(np.abs(coef) ** 2))
        content[m] = energy / total if total > 0 else 0.0
    return content


def normalise(u: dolfinx.fem.Function) -> None:
    """Scale ``u`` in place: largest nodal ``|u|`` equal to 1, slip ``u_x`` real at the origin.

    The phase reference is the interface node at ``x = y = 0`` (if its ``u_x`` vanishes, the
    entry of largest modulus), so modes from different models or runs look alike. Collective.
    """
    V = u.function_space
    comm = V.mesh.comm
    n = V.dofmap.index_map.size_local
    bs = V.dofmap.index_map_bs
    vals = u.x.array[: bs * n].reshape(n, bs)
    x = V.tabulate_dof_coordinates()[:n]
    at_origin = np.flatnonzero(np.hypot(x[:, 0], x[:, 1]) < 1e-12)
    origin = complex(vals[at_origin[0], 0]) if len(at_origin) else 0j
    origin = comm.allreduce(origin, op=MPI.SUM) if comm.size > 1 else origin
    i = int(np.argmax(np.abs(vals[:, 0]))) if n else 0
    largest = (float(abs(vals[i, 0])), complex(vals[i, 0])) if n else (0.0, 0j)
    largest = max(comm.allgather(largest), key=lambda c: c[0])
    ref = origin if abs(origin) > 1e-8 * largest[0] else largest[1]
    amp = float(np.max(np.linalg.norm(vals, axis=1))) if n else 0.0
    amp = comm.allreduce(amp, op=MPI.MAX)
    if amp > 0 and ref != 0:
        u.x.array[:] *= (abs(ref) / ref) / amp
    u.x.scatter_forward()


def _edge_values(comm: MPI.Comm, f: dolfinx.fem.Function, tol: float) -> np.ndarray:
    """``(x, values...)`` of the owned dofs of ``f`` on ``y = 0``, gathered, averaged per x."""
    W = f.function_space
    n = W.dofmap.index_map.size_local
    bs = W.dofmap.index_map_bs
    xw = W.tabulate_dof_coordinates()[:n]
    on = np.flatnonzero(np.abs(xw[:, 1]) < tol)
    rows = np.column_stack([xw[on, 0], f.x.array[: bs * n].reshape(n, bs)[on]]).astype(complex)
    rows = _allgather_rows(comm, rows)
    xs, inverse = np.unique(np.round(rows[:, 0].real, 12), return_inverse=True)
    counts = np.bincount(inverse)
    out = [xs.astype(complex)]
    for c in range(1, rows.shape[1]):
        re = np.bincount(inverse, rows[:, c].real)
        im = np.bincount(inverse, rows[:, c].imag)
        out.append((re + 1j * im) / counts)
    return np.column_stack(out)


def interface_stresses(u: dolfinx.fem.Function, lame_lambda: float, height: float
                       ) -> dict[str, np.ndarray]:
    """Stress perturbations ``sxy``, ``syy`` and slip ``u_x`` along the interface ``y = 0``.

    The stress comes from the finite-element field ``u`` on the strip (any source: a strip
    eigenvector, or the cross-section mode interpolated), interpolated into discontinuous
    Lagrange of degree ``p - 1`` (exact on simplices); values of neighbouring cells at a shared
    point are averaged. Collective; every rank gets the same arrays, sorted by ``x``.

    Returns:
        ``{"x", "sxy", "syy"}`` at the stress points and ``{"x_slip", "ux"}`` at the
        displacement nodes (``x`` real, the rest complex).
    """
    V = u.function_space
    msh = V.mesh
    degree = V.ufl_element().degree()
    W = dolfinx.fem.FunctionSpace(msh, ufl.VectorElement("DG", msh.ufl_cell(), degree - 1))
    s = sigma(u, lame_lambda, 1.0)
    t = dolfinx.fem.Function(W)
    t.interpolate(dolfinx.fem.Expression(ufl.as_vector([s[0, 1], s[1, 1]]),
                                         W.element.interpolation_points()))
    tol = 1e-10 * height
    st = _edge_values(msh.comm, t, tol)
    sl = _edge_values(msh.comm, u, tol)
    return {"x": st[:, 0].real, "sxy": st[:, 1], "syy": st[:, 2],
            "x_slip": sl[:, 0].real, "ux": sl[:, 1]}
