"""The 2D Bloch-periodic strip of a layered stack: a slider on a deformable substrate (issue 9).

The stack of :mod:`forms.models.layered` (same :class:`forms.models.layered.Stack`, same cell-wise
coefficients :func:`forms.models.layered.layer_coefficients`) extruded over one Bloch cell
``0 < x < L`` (:func:`meshes.strip.layered_strip_mesh`: triangles, separate nodes for the two
bodies at ``y = 0``, matching nodes on ``x = 0`` and ``x = L``). Fields go as
``exp(Lambda t - i k x)``; ``u(L, y) = exp(-i k L) u(0, y)``.

One map ``u_full = P u_red`` carries both the Bloch condition and the interface of
:mod:`forms.models.layered`: a right-edge node is ``exp(-i k L)`` times its left partner (same
``y``,
same body), the substrate's interface ``u_y2`` is the slider's ``u_y1`` at the same ``x``, and
the slider's interface ``u_x1 = s + u_x2`` (``s`` the slip). ``P^H A P`` then holds the
continuity of the interface tractions in the rows of ``u_y`` and ``u_x2``, and the friction
row operation (:func:`forms.friction.friction_operator` with the slider's reactions) replaces
the rows of ``s``. The interface mass ``int u_x w_x ds`` of the slider side acts on ``s``
only (reduced by ``Q``: ``P`` without the ``u_x2`` term). A rigid substrate (no substrate
layers) gives the strip of :mod:`forms.models.strip` (``u_y1 = 0`` strongly).

Stretched (PML) layers are not supported here (a 2D stretch would only act along ``y``).
"""

from __future__ import annotations

import cmath

import numpy as np

import dolfinx
import dolfinx.fem.petsc
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from analytic.params import Params
from forms.elasticity import stiffness_density
from forms.friction import (
    DIRICHLET_DIAGONAL,
    FrictionLaw,
    FrictionOperator,
    apply_dirichlet,
    friction_operator,
)
from forms.models.layered import Stack, layer_coefficients
from forms.models.periodic import reduce_matrix
from meshes.strip import layered_strip_mesh


class LayeredStrip:
    """``T(Lambda)`` of one Bloch cell of a layered stack (polynomial or split form).

    Args:
        comm: Communicator of the mesh and matrices.
        stack: The layers (no stretch) and end conditions.
        params: Friction parameters.
        length: Cell length ``L`` (one wavelength ``2 pi/k`` for the fundamental harmonic).
        nx: Columns of cells along x.
        k: Bloch wavenumber.
        degree: Lagrange degree on triangles.
        form: ``"polynomial"`` or ``"split"``.

    Attributes:
        op: The :class:`forms.friction.FrictionOperator` (solve it with :mod:`forms.solvers.slepc`).
        V: The full displacement space (both bodies).
    """

    def __init__(self, comm: MPI.Comm, stack: Stack, params: Params, length: float, nx: int,
                 k: float, degree: int = 2, form: str = "polynomial") -> None:
        if any(complex(lay.stretch) != 1.0 for lay in stack.layers()):
            raise ValueError("LayeredStrip: stretched (PML) layers are not supported")
        self.comm, self.stack, self.params = comm, stack, params
        self.length, self.nx, self.k, self.degree = float(length), int(nx), float(k), int(degree)
        self.law = FrictionLaw.from_params(params)
        self.mesh = msh = layered_strip_mesh(comm, length, stack.pieces(), nx)
        self.V = V = dolfinx.fem.FunctionSpace(
            msh, ufl.VectorElement("Lagrange", msh.ufl_cell(), self.degree))
        coef = layer_coefficients(msh, stack, axis=1)
        mu, lm, rho, chi1 = (coef[n] for n in ("mu", "lmbda", "rho", "chi1"))
        two_body = not stack.rigid
        y_top, y_bot = stack.pieces()[-1][-1], stack.pieces()[0][0]
        scale = max(self.length, y_top - y_bot)
        tol = 1e-9 * scale

        # Slider cells (midpoint above y = 0) and the slider's interface facets.
        tdim = 2
        n_cells = msh.topology.index_map(tdim).size_local + msh.topology.index_map(tdim).num_ghosts
        mid = dolfinx.mesh.compute_midpoints(msh, tdim, np.arange(n_cells, dtype=np.int32))
        slider_cells = np.flatnonzero(mid[:, 1] > 0).astype(np.int32)
        msh.topology.create_connectivity(tdim - 1, tdim)
        f2c = msh.topology.connectivity(tdim - 1, tdim)
        at0 = dolfinx.mesh.locate_entities(msh, tdim - 1, lambda x: np.isclose(x[1], 0.0))
        above = np.array([mid[f2c.links(f)[0], 1] > 0 for f in at0], dtype=bool)
        facets1 = np.sort(at0[above]) if len(at0) else at0
        tags = dolfinx.mesh.meshtags(msh, tdim - 1, facets1,
                                     np.full(len(facets1), 1, dtype=np.int32))
        ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)

        u, w = ufl.TrialFunction(V), ufl.TestFunction(V)

        def kform(weight: ufl.core.expr.Expr) -> ufl.Form:
            return weight * stiffness_density(ufl.grad(u), ufl.grad(w), lm, mu) * ufl.dx

        def mform(weight: ufl.core.expr.Expr) -> ufl.Form:
            return weight * rho * ufl.inner(u, w) * ufl.dx

        forms = [kform(1.0), mform(1.0), ufl.inner(u[0], w[0]) * ds(1)]
        if two_body:
            forms += [kform(chi1), mform(chi1)]
        full = []
        for a in forms:
            A = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(a))
            A.assemble()
            full.append(A)

        # Nodes: coordinates and body (1: slider; the two y = 0 nodes differ only by this).
        n_owned = V.dofmap.index_map.size_local
        xy = V.tabulate_dof_coordinates()[:n_owned, :2]
        ind = dolfinx.fem.Function(V)
        ind.interpolate(lambda x: np.ones((2, x.shape[1])), cells=slider_cells)
        body = np.where(ind.x.array.reshape(-1, 2)[:n_owned, 0].real > 0.5, 1, 2)
        if not two_body:
            body[:] = 1
        right = np.abs(xy[:, 0] - self.length) < tol
        left = np.abs(xy[:, 0]) < tol
        iface = np.abs(xy[:, 1]) < tol
        top = np.abs(xy[:, 1] - y_top) < tol
        bot = np.abs(xy[:, 1] - y_bot) < tol
        if (left & right).any():
            raise RuntimeError("the cell is too short")

        # Reduced numbering: drop right-edge nodes and (two bodies) the substrate's u_y at y = 0.
        keep = np.ones((n_owned, 2), dtype=bool)
        keep[right, :] = False
        if two_body:
            keep[iface & (body == 2), 1] = False
        n_red = int(keep.sum())
        offset = comm.exscan(n_red, op=MPI.SUM) or 0
        n_red_global = comm.allreduce(n_red, op=MPI.SUM)
        red = np.full((n_owned, 2), -1, dtype=np.int64)
        red[keep] = offset + np.arange(n_red)

        # Shared table of the nodes others may refer to: left edge and interface (not right).
        def key(x: float, y: float, b: int) -> tuple[int, int, int]:
            return (int(round(x / tol)), int(round(y / tol)), int(b))

        listed = (left | iface) & ~right
        mine = [(key(*xy[i], body[i]), int(red[i, 0]), int(red[i, 1]))
                for i in np.flatnonzero(listed)]
        table = {kk: (rx, ry) for part in comm.allgather(mine) for kk, rx, ry in part}
        phase = cmath.exp(-1j * self.k * self.length)

        def mapping(kk: tuple[int, int, int], slip: bool) -> tuple[list, list]:
            partner = (kk[0], kk[1], 3 - kk[2])
            if kk not in table or (two_body and kk[1] == 0 and partner not in table):
                raise RuntimeError(f"Bloch/interface pairing failed at node key {kk}")
            rx, ry = table[kk]
            if two_body and kk[1] == 0:
                other = table[partner]
                if kk[2] == 1:
                    xs = [(rx, 1.0)] + ([(other[0], 1.0)] if slip else [])
                    return xs, [(ry, 1.0)]
                return [(rx, 1.0)], [(other[1], 1.0)]
            return [(rx, 1.0)], [(ry, 1.0)]

        def build(slip: bool) -> PETSc.Mat:
            rows: list[list[tuple[int, complex]]] = []
            for i in range(n_owned):
                if right[i]:
                    base = key(0.0, xy[i, 1], body[i])
                    xs, ys = mapping(base, slip)
                    xs = [(c, phase * v) for c, v in xs]
                    ys = [(c, phase * v) for c, v in ys]
                elif listed[i]:
                    xs, ys = mapping(key(*xy[i], body[i]), slip)
                else:
                    xs, ys = [(int(red[i, 0]), 1.0)], [(int(red[i, 1]), 1.0)]
                rows += [xs, ys]
            indptr = np.zeros(len(rows) + 1, dtype=PETSc.IntType)
            indptr[1:] = np.cumsum([len(r) for r in rows])
            cols = np.array([c for r in rows for c, _ in r], dtype=PETSc.IntType)
            vals = np.array([v for r in rows for _, v in r], dtype=PETSc.ScalarType)
            if (cols < 0).any():
                raise RuntimeError("Bloch/interface pairing failed (a node has no partner)")
            m = PETSc.Mat().createAIJ(((2 * n_owned, PETSc.DECIDE), (n_red, n_red_global)),
                                      csr=(indptr, cols, vals), comm=comm)
            m.assemble()
            return m

        self.P = build(True)
        Q = build(False)
        K, M = (reduce_matrix(a, self.P) for a in full[:2])
        B = reduce_matrix(full[2], Q)
        reactions = None
        if two_body:
            reactions = (reduce_matrix(full[3], self.P), reduce_matrix(full[4], self.P))
        Q.destroy()
        for a in full:
            a.destroy()
        fr = np.flatnonzero(iface & (body == 1) & ~right)
        self.interface_x, self.interface_y = red[fr, 0], red[fr, 1]
        dirichlet = []
        for cond, nodes in ((stack.top, top), (stack.bottom if two_body else "", bot)):
            sel = np.flatnonzero(nodes & ~right)
            if cond in ("velocity", "clamped"):
                dirichlet.append(red[sel, 0])
            if cond == "clamped":
                dirichlet.append(red[sel, 1])
        if not two_body:
            dirichlet.append(self.interface_y)
        dofs = np.concatenate(dirichlet).astype(np.int64) if dirichlet else np.zeros(0, np.int64)
        self.dirichlet_dofs = dofs
        self.op: FrictionOperator = friction_operator(
            self.law, K, M, B, self.interface_x, self.interface_y, form=form,
            reactions=reactions)
        apply_dirichlet(self.op.matrices, dofs, self.op.constant_term, DIRICHLET_DIAGONAL)
        for a in (K, M, B, *(reactions or ())):
            a.destroy()

    @property
    def size(self) -> int:
        """Global number of (reduced) unknowns."""
        return self.op.matrices[0].getSize()[0]

    def to_function(self, x: PETSc.Vec, name: str = "u") -> dolfinx.fem.Function:
        """The full displacement ``u = P x`` on both bodies (ghosts updated)."""
        u = dolfinx.fem.Function(self.V, name=name)
        self.P.mult(x, u.vector)
        u.x.scatter_forward()
        return u

    def destroy(self) -> None:
        """Destroy the PETSc objects."""
        self.op.destroy()
        self.P.destroy()


def mode_data(strip: LayeredStrip, u: dolfinx.fem.Function) -> dict[str, np.ndarray] | None:
    """Gather a mode on rank 0: node ``x, y``, ``body`` (1 slider, 2 substrate), ``ux, uy``.

    Returns ``None`` on the other ranks (collective call). The phase is normalised so that the
    largest displacement component is real and positive.
    """
    V = strip.V
    n_owned = V.dofmap.index_map.size_local
    xy = V.tabulate_dof_coordinates()[:n_owned, :2]
    vals = u.x.array.reshape(-1, 2)[:n_owned]
    ind = dolfinx.fem.Function(V)
    mid = dolfinx.mesh.compute_midpoints(
        strip.mesh, 2, np.arange(strip.mesh.topology.index_map(2).size_local
                                 + strip.mesh.topology.index_map(2).num_ghosts, dtype=np.int32))
    ind.interpolate(lambda x: np.ones((2, x.shape[1])),
                    cells=np.flatnonzero(mid[:, 1] > 0).astype(np.int32))
    body = np.where(ind.x.array.reshape(-1, 2)[:n_owned, 0].real > 0.5, 1, 2)
    parts = strip.comm.gather(np.column_stack([xy, body, vals]), root=0)
    if strip.comm.rank != 0:
        return None
    a = np.concatenate(parts)
    uv = a[:, 3:5]
    big = uv.ravel()[np.argmax(np.abs(uv.ravel()))]
    uv = uv * (abs(big) / big)
    return {"x": a[:, 0].real, "y": a[:, 1].real, "body": a[:, 2].real.astype(int),
            "ux": uv[:, 0], "uy": uv[:, 1]}


def plot_mode(data: dict[str, np.ndarray], path: str, title: str, amplitude: float = 0.08
              ) -> None:
    """Picture of a two-body mode: deformed bodies coloured by ``Re u_y``, interface profiles.

    Left: both bodies, nodes moved by ``amplitude * Re u / max|u|``, with deformed material
    lines ``x = const`` (the slip shows as their offset at ``y = 0``). Right: ``Re`` of
    ``u_x1``, ``u_x2``, the slip ``u_x1 - u_x2`` and ``u_y`` along the interface.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.tri import Triangulation

    umax = float(np.max(np.hypot(np.abs(data["ux"]), np.abs(data["uy"]))))
    scale = amplitude * (data["y"].max() - data["y"].min()) / umax
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True,
                                 gridspec_kw={"width_ratios": [1.4, 1]})
    vmax = float(np.abs(data["uy"].real).max())
    for b in (1, 2):
        sel = data["body"] == b
        if not sel.any():
            continue
        x, y = data["x"][sel], data["y"][sel]
        tri = Triangulation(x, y)  # each body is a rectangle: Delaunay of its nodes is fine
        xd = x + scale * data["ux"][sel].real
        yd = y + scale * data["uy"][sel].real
        tri_d = Triangulation(xd, yd, tri.triangles)
        pc = ax.tripcolor(tri_d, data["uy"][sel].real, shading="gouraud", cmap="RdBu_r",
                          vmin=-vmax, vmax=vmax)
    # Deformed material lines x = const: the slip is their offset at y = 0.
    xs_all, counts = np.unique(np.round(data["x"], 12), return_counts=True)
    xs_all = xs_all[counts == counts.max()]  # full columns (mesh vertex lines) only
    for x0 in xs_all[:: max(1, len(xs_all) // 12)]:
        for b in (1, 2):
            sel = np.flatnonzero((data["body"] == b) & np.isclose(data["x"], x0))
            sel = sel[np.argsort(data["y"][sel])]
            ax.plot(data["x"][sel] + scale * data["ux"][sel].real,
                    data["y"][sel] + scale * data["uy"][sel].real, "k", lw=0.6)
    ax.axhline(0.0, color="k", lw=0.6, ls=":")
    ax.set_xlabel("x")
    ax.set_ylabel("y  (slider y > 0, substrate y < 0)")
    ax.set_title(f"deformed (x {scale:.2g}), colour Re u_y", fontsize=9)
    fig.colorbar(pc, ax=ax, shrink=0.8)
    i1 = np.flatnonzero((data["body"] == 1) & np.isclose(data["y"], 0.0))
    i2 = np.flatnonzero((data["body"] == 2) & np.isclose(data["y"], 0.0))
    i1, i2 = i1[np.argsort(data["x"][i1])], i2[np.argsort(data["x"][i2])]
    xi = data["x"][i1]
    bx.plot(xi, data["ux"][i1].real, label="Re u_x slider")
    if len(i2):
        bx.plot(data["x"][i2], data["ux"][i2].real, label="Re u_x substrate")
        bx.plot(xi, (data["ux"][i1] - data["ux"][i2]).real, "k", lw=2, label="Re slip")
        bx.plot(data["x"][i2], data["uy"][i2].real, "--", label="Re u_y substrate")
    bx.plot(xi, data["uy"][i1].real, ":", lw=2, label="Re u_y slider")
    bx.set_xlabel("x (interface y = 0)")
    bx.legend(fontsize=8)
    bx.set_title("interface: u_y continuous, u_x slips", fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)
