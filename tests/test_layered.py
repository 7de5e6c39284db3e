"""Layered cross-section model (forms/models/section.py): rigid limit, two bodies vs exact, PML
layers.

Runs serially and under ``mpirun -n 2 python -m mpi4py -m pytest`` (``world``: one mesh
distributed over both ranks; ``self``: one mesh per rank). The exact two-body roots come from
:func:`analytic.physics.twobody.det_twobody`, polished (Newton) from each FE root.
"""

import logging
import math

import numpy as np
import pytest

from mpi4py import MPI

from analytic.numerics.roots import polish
from analytic.numerics.tracking import normalized
from analytic.params import Params
from analytic.physics import largek
from analytic.physics.halfspace import dilatational_root
from analytic.physics.twobody import det_twobody
from forms.models.cross_section import CrossSectionModel
from forms.models.pml import HalfSpaceModel, design_layer
from forms.models.profiles import LayerRow, Profile
from forms.models.section import (
    Layer,
    SectionModel,
    Stack,
    contour_samples,
    pml_layers,
    pml_stack,
    stack_from_layers,
    stack_from_params,
)
from forms.solvers.slepc import PolynomialSolver, SplitSolver

logging.disable(logging.INFO)
COMMS = {"world": MPI.COMM_WORLD, "self": MPI.COMM_SELF}
# docs/design.md section 4: velocity top, paper defaults, H = 0.5, k = 1, branch 0-.
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j

# Two-body cases: both tops, both bottoms, finite H2, identical materials, generalized friction.
TWO_BODY = {
    "vel-stress": Params(mu2=2.0, rho2=1.5, beta2=0.55, H2=0.7, bc2="stress"),
    "vel-vel": Params(mu2=2.0, rho2=1.5, beta2=0.55, H2=0.7, bc2="velocity"),
    "stress-vel": Params(bc="stress", mu2=0.8, rho2=1.2, beta2=0.45, H2=0.4, bc2="velocity"),
    "stress-stress": Params(bc="stress", mu2=0.8, rho2=1.2, beta2=0.45, H2=0.4, bc2="stress"),
    "identical": Params(mu2=1.0, rho2=1.0, H2=0.5, bc2="velocity"),
    "pc-ld": Params(alpha_pc=0.3, alpha_ld=0.2, mu2=3.0, rho2=2.0, beta2=0.5, H2=1.0,
                    bc2="velocity"),
    "pc-weakening": Params(bc="stress", Delta=-0.3, alpha_pc=0.5, mu2=0.5, rho2=0.8, H2=2.0,
                           bc2="stress"),
}


def _sorted_dense(model) -> tuple[np.ndarray, np.ndarray]:
    """Permutation of the dofs by (y, component) for a serial model."""
    y = model.V.tabulate_dof_coordinates()[:, 0]
    order = np.argsort(y, kind="stable")
    return np.ravel(np.column_stack([2 * order, 2 * order + 1]))


@pytest.mark.parametrize("p", [Params(), Params(bc="stress", alpha_pc=0.3, alpha_ld=0.2)])
def test_rigid_stack_is_the_cross_section_model(p):
    """mu2 = inf: the same matrices (entry by entry, dofs sorted by y) as CrossSectionModel."""
    cs = CrossSectionModel(MPI.COMM_SELF, p, degree=4, cells=6, k_max=3.0)
    lm = SectionModel(MPI.COMM_SELF, stack_from_params(p, degree=4, cells=6, k_max=3.0), p,
                      degree=4)
    assert lm.stack.rigid and lm.size == cs.size
    pa, pb = _sorted_dense(cs), _sorted_dense(lm)
    for k in (0.5, 3.0):
        for A, B in zip(cs.operator(k).matrices, lm.operator(k).matrices, strict=True):
            a = A.convert("dense").getDenseArray()[np.ix_(pa, pa)]
            b = B.convert("dense").getDenseArray()[np.ix_(pb, pb)]
            # measured: identical (difference exactly 0), 2026-11-22.
            assert np.abs(a - b).max() <= 1e-15 * np.abs(a).max()
    cs.destroy()
    lm.destroy()


@pytest.mark.parametrize("comm_name", ["world", "self"])
def test_rigid_stack_check_value(comm_name):
    """The project's check value through the layered model (P3, 20 cells, as the FE test)."""
    comm = COMMS[comm_name]
    p = Params()
    lm = SectionModel(comm, stack_from_params(p, degree=3, cells=20), p, degree=3)
    cs = CrossSectionModel(comm, p, degree=3, cells=20)
    solver = PolynomialSolver(comm, nev=1)
    lams = []
    for model in (lm, cs):
        res = solver.solve(model.operator(1.0), -6.6j)
        lams.append(res.pairs[0].value)
        res.destroy()
    # measured 5.8e-12 from the check value (the FE error); the two models differ by 1.1e-14
    # serial, 2.1e-15 on 2 ranks (same matrices, eigen-solver round-off), 2026-11-22.
    assert abs(lams[0] - CHECK_VALUE) < 2e-11 * abs(CHECK_VALUE)
    assert abs(lams[0] - lams[1]) < 1e-13 * abs(lams[1])
    solver.destroy()
    lm.destroy()
    cs.destroy()


@pytest.mark.parametrize("name", list(TWO_BODY))
def test_two_body_roots_match_exact(name):
    """FE (P4, default cells) vs det_twobody: the four roots nearest -2i at k = 0.5 and 2."""
    p = TWO_BODY[name]
    comm = MPI.COMM_WORLD
    model = SectionModel(comm, stack_from_params(p, degree=4, k_max=2.0), p, degree=4)
    solver = PolynomialSolver(comm, nev=4)
    for k in (0.5, 2.0):
        _check_against_exact(model, solver, p, k)
    solver.destroy()
    model.destroy()


def _check_against_exact(model, solver, p, k):
    res = solver.solve(model.operator(k), -2.0j)
    assert len(res.pairs) >= 4
    for pair in res.pairs[:4]:
        root = polish(lambda L: det_twobody(L, k, p), pair.value)  # noqa: B023
        assert root.converged
        # measured max 9.5e-10 (serial; 9.4e-10 on 2 ranks) over all cases, k and roots, P4,
        # default cells, 2026-11-22. The largest errors are on the small roots |Lambda| ~ 0.05
        # of "stress-stress" (absolute 5e-11): a round-off floor, not the discretisation (it
        # grows to 3e-9 on 30+30 cells, while det_twobody and det_twobody_propagator agree to
        # 1e-14 there). The other roots: <= 6e-11. The bound is 1e-8.
        assert abs(pair.value - root.value) <= 3e-9 * abs(root.value)
        assert pair.residual < 1e-12  # measured <= 4.8e-14
    res.destroy()


@pytest.mark.parametrize("cells", [(4, 4), (6, 12)])
def test_two_body_fe_converges_to_exact(cells):
    """The long soft substrate of "pc-weakening" on coarse meshes: the error falls with h."""
    p = TWO_BODY["pc-weakening"]
    model = SectionModel(MPI.COMM_SELF, stack_from_params(p, degree=4, cells=cells[0],
                                                          cells2=cells[1]), p, degree=4)
    solver = PolynomialSolver(MPI.COMM_SELF, nev=4)
    res = solver.solve(model.operator(2.0), -2.0j)
    errs = [abs(q.value - polish(lambda L: det_twobody(L, 2.0, p), q.value).value)  # noqa: B023
            / abs(q.value) for q in res.pairs[:4]]
    # measured max 7.7e-7 (4+4 cells) and 1.3e-10 (6+12 cells), 2026-11-22.
    bound = {(4, 4): 2e-6, (6, 12): 1e-9}[cells]
    assert max(errs) < bound
    if cells == (4, 4):
        assert max(errs) > 1e-8  # the coarse mesh is visibly coarse: the check can fail
    res.destroy()
    solver.destroy()
    model.destroy()


def test_split_form_two_bodies_matches_polynomial():
    """NEP split form (no spurious roots) and PEP give the same two-body root."""
    p = TWO_BODY["pc-ld"]
    lam = {}
    for form, cls in (("polynomial", PolynomialSolver), ("split", SplitSolver)):
        model = SectionModel(MPI.COMM_SELF, stack_from_params(p, degree=4, cells=6, cells2=6),
                             p, degree=4, form=form)
        solver = cls(MPI.COMM_SELF, nev=1)
        res = solver.solve(model.operator(1.0), -0.77j)
        lam[form] = res.pairs[0].value
        res.destroy()
        solver.destroy()
        model.destroy()
    # measured difference 2.7e-13 (same discretisation, different algebra), 2026-11-22.
    assert abs(lam["polynomial"] - lam["split"]) < 1e-11 * abs(lam["split"])


def test_stiff_substrate_approaches_rigid():
    """mu2 -> inf (rho2 = 1, H2 = H): the root tends to the rigid one like 1/mu2."""
    comm = MPI.COMM_SELF
    p = Params()
    solver = PolynomialSolver(comm, nev=1)
    rigid = SectionModel(comm, stack_from_params(p, degree=4, cells=6), p, degree=4)
    res = solver.solve(rigid.operator(1.0), -6.6j)
    lam0 = res.pairs[0].value
    res.destroy()
    rigid.destroy()
    diffs = []
    for mu2 in (1e6, 1e8, 1e10):
        q = p.replace(mu2=mu2, rho2=1.0, H2=0.5, bc2="stress")
        model = SectionModel(comm, stack_from_params(q, degree=4, cells=6, cells2=6), q,
                             degree=4)
        res = solver.solve(model.operator(1.0), lam0)
        diffs.append(abs(res.pairs[0].value - lam0) / abs(lam0))
        res.destroy()
        model.destroy()
    solver.destroy()
    # measured 2.319e-4, 2.318e-6, 2.318e-8: ratios 100.05, 100.00 (first order in 1/mu2).
    assert diffs[0] < 1e-3 and diffs[2] < 1e-7
    for a, b in zip(diffs, diffs[1:], strict=False):
        assert 90.0 < a / b < 110.0


@pytest.mark.parametrize("comm_name", ["world", "self"])
def test_stretched_layer_is_the_halfspace_model(comm_name):
    """Rigid half-space: a PML as a stretched Layer equals forms.models.pml.HalfSpaceModel."""
    comm = COMMS[comm_name]
    p = Params(H=math.inf)
    q = 0.3
    exact = dilatational_root(q, p)
    target = complex(-1j * q * largek.z_linear(q, p))
    design = design_layer(q, target, p.beta, 4)
    hs = HalfSpaceModel(comm, p, design, 4)
    lm = SectionModel(comm, Stack(pml_layers(design, "slider", beta=p.beta), top="clamped"),
                      p, 4)
    solver = PolynomialSolver(comm, nev=1)
    a = solver.solve(hs.op, target)
    b = solver.solve(lm.operator(q), target)
    la, lb = a.pairs[0].value, b.pairs[0].value
    # measured 1.7e-16 between the two models and 9.3e-14 from the exact root (serial),
    # 2026-11-22.
    assert abs(la - lb) < 1e-13 * abs(la)
    assert abs(lb - exact.Lambda) < 1e-12 * abs(exact.Lambda)
    for r in (a, b):
        r.destroy()
    solver.destroy()
    hs.destroy()
    lm.destroy()


HALF_SPACES = {
    "substrate": (Params(mu2=2.0, rho2=1.5, beta2=0.55, H2=math.inf), -1.2 + 0j),
    "slider": (Params(H=math.inf, mu2=2.0, rho2=1.5, beta2=0.55, H2=0.7, bc2="stress"),
               -1.2 + 0j),
    "both": (Params(H=math.inf, mu2=2.0, rho2=1.5, beta2=0.55, H2=math.inf), -1.2 + 0j),
    "both-soft": (Params(H=math.inf, mu2=0.6, rho2=1.0, H2=math.inf, gamma=1.0), -0.5 - 0.5j),
}


@pytest.mark.parametrize("name", list(HALF_SPACES))
def test_halfspaces_with_pml_layers(name):
    """H and/or H2 infinite: PML layers (pml_stack) vs det_twobody, root nearest the target."""
    p, target = HALF_SPACES[name]
    k = 1.0
    stack = pml_stack(p, k, target)
    assert (stack.top == "clamped") == (not math.isfinite(p.H))
    assert (stack.bottom == "clamped") == (not math.isfinite(p.H2))
    model = SectionModel(MPI.COMM_WORLD, stack, p, 4)
    solver = PolynomialSolver(MPI.COMM_WORLD, nev=1)
    res = solver.solve(model.operator(k), target)
    lam = res.pairs[0].value
    root = polish(lambda L: det_twobody(L, k, p), lam)
    assert root.converged
    # measured 4.1e-11, 1.1e-10, 1.2e-10, 2.7e-9 (P4, default layers designed for the
    # target), serial and 2 ranks, 2026-11-22. Roots far from the target are not resolved
    # by a layer designed for it (measured 1e-7 .. 1e-3): only the nearest is checked.
    assert abs(lam - root.value) < 1e-8 * abs(root.value)
    res.destroy()
    solver.destroy()
    model.destroy()


def test_interface_conditions_hold_on_the_mode():
    """Mode shape: u_y continuous at y = 0, slip nonzero; world and self meshes agree."""
    p = TWO_BODY["vel-stress"]
    out = {}
    for name, comm in COMMS.items():
        model = SectionModel(comm, stack_from_params(p, degree=4, cells=6, cells2=6), p, 4)
        solver = PolynomialSolver(comm, nev=1)
        res = solver.solve(model.operator(1.0), -1.9j)
        vec = model.canonical(res.pairs[0].vector)
        slip = model.slip(res.pairs[0].vector)
        out[name] = (res.pairs[0].value, vec, slip)
        res.destroy()
        solver.destroy()
        model.destroy()
    if MPI.COMM_WORLD.rank == 0:
        (lw, vw, sw), (ls, vs, ss) = out["world"], out["self"]
        assert abs(lw - ls) < 1e-11 * abs(ls)  # measured 3.7e-15 (2 ranks), 0 serially
        zero = np.isclose(vs[:, 0].real, 0.0)
        assert zero.sum() == 2 and set(vs[zero, 1].real) == {1.0, 2.0}
        u = normalized(vs[:, 2:]).reshape(-1, 2)
        uz = u[zero]
        assert abs(uz[0, 1] - uz[1, 1]) < 1e-13 * np.abs(u).max()  # u_y tied: exact
        assert abs(uz[0, 0] - uz[1, 0]) > 1e-3 * np.abs(u).max()  # the bodies slip
        assert abs(ss) > 0 and abs(sw) > 0
        overlap = abs(np.vdot(normalized(vw[:, 2:]), normalized(vs[:, 2:])))
        assert overlap > 1 - 1e-10


@pytest.mark.serial
def test_stack_validation():
    v = np.linspace(0.0, 1.0, 3)
    with pytest.raises(ValueError, match="start at y = 0"):
        Stack((Layer(v + 1.0),))
    with pytest.raises(ValueError, match="contiguous"):
        Stack((Layer(v), Layer(v + 1.5)))
    with pytest.raises(ValueError, match="top"):
        Stack((Layer(v),), top="free")
    with pytest.raises(ValueError, match="material"):
        Layer(v, mu=-1.0)
    s = Stack((Layer(v),), (Layer(-v[::-1], mu=2.0),), bottom="velocity")
    pieces = s.pieces()
    assert len(pieces) == 2 and pieces[0][-1] == 0.0 and pieces[1][0] == 0.0


def test_k_blocks_recombine_to_the_operator():
    """Both models expose T0, T1, T2; T0 + k T1 + k^2 T2 is operator(k) (same matrices)."""
    p = TWO_BODY["pc-ld"]
    models = [CrossSectionModel(MPI.COMM_WORLD, Params(), degree=2, cells=6),
              SectionModel(MPI.COMM_WORLD, stack_from_params(p, degree=2, cells=4, cells2=4), p,
                           degree=2)]
    k = 1.7
    for model in models:
        parts = model.k_blocks()
        assert len(parts) == 3
        for j, a in enumerate(model.operator(k).matrices):
            b = parts[0].matrices[j].duplicate(copy=True)
            b.axpy(k, parts[1].matrices[j])
            b.axpy(k * k, parts[2].matrices[j])
            b.axpy(-1.0, a)
            # measured: 0 (the same axpy sequence), 2026-11-22.
            assert b.norm() <= 1e-14 * max(a.norm(), 1.0)
            b.destroy()
        model.destroy()


def test_spatial_roots_work_on_two_bodies():
    """forms.solvers.spatial_stability.spatial_roots (a PEP in k from the k-blocks) recovers k."""
    from forms.solvers.spatial_stability import spatial_roots

    p = TWO_BODY["vel-stress"]
    comm = MPI.COMM_WORLD
    model = SectionModel(comm, stack_from_params(p, degree=4, cells=6, cells2=6), p, 4)
    solver = PolynomialSolver(comm, nev=1)
    res = solver.solve(model.operator(1.3), -2.0j)
    lam = res.pairs[0].value
    res.destroy()
    solver.destroy()
    ks = spatial_roots(model, lam, 1.25, nev=1)
    model.destroy()
    # measured |k - 1.3| = 5.7e-14 (serial), 6.1e-14 (2 ranks), 2026-11-22.
    assert abs(ks[0] - 1.3) < 1e-11


def _symmetric_roots(bc: str, delta: float, k: float) -> tuple[list[complex], list[float]]:
    """Roots of the symmetric identical stack at k, and each neutral root's distance to the
    nearest "roller" mode (one body, u_y = 0 and sigma_xy = 0 at y = 0: the rigid model with
    f = 0 and 1/gamma ~ 0)."""
    comm = MPI.COMM_SELF
    p = Params(bc=bc, Delta=delta, mu2=1.0, rho2=1.0, H2=0.5, bc2=bc)
    model = SectionModel(comm, stack_from_params(p, degree=4, cells=8, cells2=8, k_max=3.0),
                         p, 4)
    q = Params(bc=bc, f=0.0, gamma=1e14)
    roller = SectionModel(comm, stack_from_params(q, degree=4, cells=8, k_max=3.0), q, 4)
    solver = PolynomialSolver(comm, nev=10)
    roots, dist = [], []
    for target in (-1j, -5j, -10j, -0.5 + 0j, -0.4j):
        res = solver.solve(model.operator(k), target)
        for pair in res.pairs:
            roots.append(pair.value)
            if abs(pair.value.real) < 1e-8:
                ref = solver.solve(roller.operator(k), pair.value, nev=1)
                dist.append(abs(ref.pairs[0].value - pair.value) / abs(pair.value))
                ref.destroy()
        res.destroy()
    solver.destroy()
    model.destroy()
    roller.destroy()
    return roots, dist


@pytest.mark.parametrize("delta", [0.7, 0.0])
@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_symmetric_identical_stack_does_not_grow(bc, delta):
    """mu2 = rho2 = 1, beta2 = beta, H2 = H, bc2 = bc, Delta >= 0: no growth; neutral modes.

    By the mirror symmetry, the part of a mode with u_x odd / u_y even in y has
    sigma_yy(0) = 0: its slip obeys a friction law without normal-stress coupling, damped for
    Delta >= 0. The part with u_x even / u_y odd has no slip, u_y(0) = 0 and sigma_xy(0) = 0:
    the elastic modes of one body on a frictionless roller interface, undamped. Their
    sigma_yy(0) is balanced by the slip part through f sigma_yy, so each roller mode is an
    eigenvalue of the stack with Re Lambda = 0 exactly.
    """
    roots, dist = _symmetric_roots(bc, delta, 1.0)
    assert len(roots) >= 15  # measured 17-20 converged roots (with repeats) at k = 1
    # measured max Re Lambda <= 2.6e-12 (round-off of purely imaginary roots), 2026-11-22.
    assert max(r.real for r in roots) < 1e-10
    assert len(dist) >= 4  # neutral roots found (measured 5-8)
    # measured <= 8.4e-13: the neutral roots are the roller modes of one body.
    assert max(dist) < 1e-10


def test_symmetric_identical_stack_grows_when_velocity_weakening():
    """The same stack with Delta < 0 has a growing (slip) mode: the check can fail."""
    roots, _ = _symmetric_roots("velocity", -0.3, 1.0)
    # measured Lambda = 0.01229 +- 0.3862i at k = 1 (stress top: Re 0.0084), 2026-11-22.
    assert max(r.real for r in roots) > 1e-3


@pytest.mark.parametrize("bc,k,target", [("velocity", 10**0.25, -9.0j), ("stress", 1.0, -8.5j)])
def test_broken_symmetry_grows(bc, k, target):
    """Identical materials, H2 = H/2 (Delta = 0.7): a growing mode, confirmed by det_twobody."""
    p = Params(bc=bc, Delta=0.7, mu2=1.0, rho2=1.0, H2=0.25, bc2=bc)
    model = SectionModel(MPI.COMM_WORLD, stack_from_params(p, degree=4, k_max=10.0, n_max=1), p,
                         4)
    solver = PolynomialSolver(MPI.COMM_WORLD, nev=1)
    res = solver.solve(model.operator(k), target)
    lam = res.pairs[0].value
    root = polish(lambda L: det_twobody(L, k, p), lam)
    # measured Lambda = 0.0546966 - 8.95254i (velocity) and 0.215378 - 8.45276i (stress),
    # FE = exact to the digits shown, 2026-11-22.
    assert root.converged and abs(lam - root.value) < 1e-8 * abs(root.value)
    assert root.value.real > 0.01
    res.destroy()
    solver.destroy()
    model.destroy()


@pytest.mark.serial
def test_wave_time_is_the_s_plus_p_travel_time():
    """``Stack.wave_time``: ``H (1 + beta)`` for the homogeneous slider (the exact count's
    rule, ``analytic.numerics.branches._n_initial``), the sum over layers and bodies, and a
    profile's integral (trapezoid on 8 points per interval against an adaptive quadrature)."""
    from scipy.integrate import quad

    from analytic.numerics.branches import _n_initial

    p = Params(bc="stress", H=3.0, beta=0.4)
    stack = stack_from_params(p)
    assert stack.wave_time == pytest.approx(3.0 * 1.4, rel=1e-14)
    box = (-0.01, 2.0, -500.0, 500.0)
    assert contour_samples(stack, box) == _n_initial(p, box)
    assert contour_samples(stack, (0.0, 0.1, 0.0, 0.1)) == 32  # never below the old start
    two = stack_from_params(Params(mu2=4.0, rho2=2.0, beta2=0.3, H2=2.0))
    assert two.wave_time == pytest.approx(0.5 * 1.5 + 2.0 * 1.3 / math.sqrt(2.0), rel=1e-14)
    rows = [LayerRow(0.2, 0.25, 1.5, 0.45), LayerRow(1.0, 1.0, 1.0, 0.5)]
    layered = stack_from_layers(Params(), rows)
    assert layered.wave_time == pytest.approx(
        0.2 * 1.45 * math.sqrt(1.5 / 0.25) + 0.8 * 1.5, rel=1e-14)
    mu = Profile("1 - 0.6*exp(-y/0.05)", "mu")
    graded = stack_from_layers(Params(), [LayerRow(1.0, 1.0, 1.0, 0.5)], profiles={"mu": mu})
    ref = quad(lambda y: 1.5 / math.sqrt(float(mu(np.array([y]))[0])), 0.0, 1.0,
               points=[0.05, 0.2], epsabs=1e-13)[0]
    # trapezoid with 8 sub-points per interval of the default mesh (k_max = 1: coarse against
    # the profile's scale 0.05): measured 1.2e-4 relative; the sampling rule needs ~10 %
    assert graded.wave_time == pytest.approx(ref, rel=1e-3)
    assert graded.wave_time != pytest.approx(1.5, rel=1e-2)  # the profile counts
