"""The 2D model with two bodies (forms.models.strip): Bloch cell and finite block against the
exact two-body roots, the mode of both bodies, the friction profile, and the scenes."""

import json
import math
import sys

import numpy as np
import pytest

import slepc4py

slepc4py.init(sys.argv[:1])

from _workflows import run_workflow  # noqa: E402

from mpi4py import MPI  # noqa: E402
from petsc4py import PETSc  # noqa: E402

from analytic.numerics.branches import follow_branch, polish_root  # noqa: E402
from analytic.params import Params  # noqa: E402
from forms.models.strip import (  # noqa: E402
    FrictionProfile,
    build_strip_problem,
    friction_operator_for,
    solve_modes,
    strip_mesh_for,
)
from forms.studies import strip_mode  # noqa: E402

COMM = MPI.COMM_WORLD
#: Two-body cases of tests/test_layered.py (velocity top on a stress-free-bottom substrate, and
#: a stress top on a velocity-bottom substrate).
CASES = {
    "vel-stress": Params(mu2=2.0, rho2=1.5, beta2=0.55, H2=0.7, bc2="stress"),
    "stress-vel": Params(bc="stress", mu2=0.8, rho2=1.2, beta2=0.45, H2=0.4, bc2="velocity"),
}
SUBSTRATE = ["--mu2", "2", "--rho2", "1.5", "--beta2", "0.55", "--H2", "0.7", "--bc2", "stress"]


def _exact(p: Params, k: float) -> complex:
    """The exact root of branch 0- at ``k`` (followed from its cut-off)."""
    res = follow_branch(p, 0, -1, np.array([k]))
    assert res.ok[0]
    return complex(res.Lambda[0])


def _solve(p, length, nx, ny, k, target, degree=2, lateral="free", friction=None, nev=3):
    strip = strip_mesh_for(COMM, p, length, nx, ny)
    problem = build_strip_problem(strip, p, k=k, degree=degree, lateral=lateral,
                                  friction=friction)
    modes = solve_modes(problem, target, nev=nev)
    return problem, modes


def _destroy(problem, modes):
    for m in modes:
        m.vector.destroy()
    problem.destroy()


# Relative errors against the exact root of branch 0- at k = 1 (P2, one wavelength, no
# grading), measured 2026-11-24, serial and 2 ranks alike: vel-stress 6.97e-4 (8 x 4 cells per
# body), 4.91e-5 (16 x 8); stress-vel 5.51e-4, 4.30e-5: about order 4 in h (ratios 14, 13).
@pytest.mark.parametrize("case,measured", [("vel-stress", (6.97e-4, 4.91e-5)),
                                           ("stress-vel", (5.51e-4, 4.30e-5))])
def test_bloch_cell_converges_to_the_exact_two_body_root(case, measured):
    p, k = CASES[case], 1.0
    exact = _exact(p, k)
    errs = []
    for nx, ny in ((8, 4), (16, 8)):
        problem, modes = _solve(p, 2 * math.pi / k, nx, ny, k, exact)
        best = min(modes, key=lambda m: abs(m.eigenvalue - exact))
        assert best.harmonic == 0
        assert best.residual < 1e-12  # measured <= 1e-16
        errs.append(abs(best.eigenvalue - exact) / abs(exact))
        _destroy(problem, modes)
    for e, m in zip(errs, measured, strict=True):
        assert 0.5 * m < e < 1.05 * m


def test_two_body_mode_ties_u_y_and_slips():
    """u_y is one unknown on both sides of y = 0; u_x jumps (the slip)."""
    p, k = CASES["vel-stress"], 1.0
    problem, modes = _solve(p, 2 * math.pi, 8, 4, k, _exact(p, k), nev=1)
    u = problem.to_function(modes[0].vector)
    sides = strip_mode._side_values(u, 1e-10)
    data = strip_mode.interface_of(u, p)
    _destroy(problem, modes)
    one, two = sides[1], sides[2]
    assert len(one) == len(two) == 2 * 8 + 1  # P2, 8 cells, both ends
    np.testing.assert_array_equal(one[:, 0], two[:, 0])
    umax = np.abs(np.concatenate([one[:, 1:], two[:, 1:]])).max()
    assert np.abs(one[:, 2] - two[:, 2]).max() < 1e-13 * umax  # tied: equal to rounding
    assert np.abs(one[:, 1] - two[:, 1]).max() > 0.1 * umax  # the bodies slip
    np.testing.assert_allclose(data["ux"], one[:, 1] - two[:, 1], atol=1e-14 * umax)
    assert len(data["x"]) == 8 + 1  # P1 stress points of the slider's side
    assert np.abs(data["syy"]).max() > 0.1 * umax


# A block with rollers at both ends (u_x = 0) and f = 0 (the law then couples only terms odd in
# x) holds the standing wave sin/cos(q x), q = n pi/L, of the infinite strip exactly: its
# eigenvalue is the exact two-body root at k = q. Relative errors measured 2026-11-24 (P2,
# L = 2 pi, n = 2), serial and 2 ranks: 8.73e-5 (2 cells per unit length, 3 per body in y),
# 9.63e-6 (4, 6).
def test_roller_block_holds_the_exact_standing_wave():
    p = Params(f=0.0, mu2=2.0, rho2=1.5, beta2=0.55, H2=0.7, bc2="stress")
    length = 2 * math.pi
    exact = polish_root(p, 2 * math.pi / length, -0.1 - 1.95j).value
    errs = []
    for cells, ny in ((2, 3), (4, 6)):
        problem, modes = _solve(p, length, int(cells * length), ny, None, exact, lateral="roller")
        errs.append(min(abs(m.eigenvalue - exact) for m in modes) / abs(exact))
        _destroy(problem, modes)
    assert 0.5 * 8.73e-5 < errs[0] < 1.05 * 8.73e-5
    assert 0.5 * 9.63e-6 < errs[1] < 1.05 * 9.63e-6


@pytest.mark.parametrize("lateral", ["free", "clamped"])
def test_two_body_block_is_real(lateral):
    """No Bloch phase: real operators, the spectrum symmetric under conjugation."""
    p = CASES["stress-vel"]
    strip = strip_mesh_for(COMM, p, 4.0, 16, 3)
    problem = build_strip_problem(strip, p, k=None, degree=2, lateral=lateral)
    for A in (problem.stiffness, problem.mass, problem.interface_mass, *problem.reactions):
        assert np.max(np.abs(A.getValuesCSR()[2].imag), initial=0.0) == 0.0
    down = solve_modes(problem, -0.1 - 2.0j, nev=3)
    up = solve_modes(problem, -0.1 + 2.0j, nev=3)
    for m in down:
        partner = min(up, key=lambda q: abs(q.eigenvalue - m.eigenvalue.conjugate()))
        assert abs(partner.eigenvalue - m.eigenvalue.conjugate()) < 1e-9 * abs(m.eigenvalue)
    for m in down + up:
        m.vector.destroy()
    problem.destroy()


def _patch(inside, outside, x0, x1):
    return lambda x: np.where((x >= x0) & (x <= x1), inside, outside)


@pytest.mark.parametrize("two_body", [False, True])
def test_uniform_patch_gives_the_uniform_block(two_body):
    """A 'patch' whose values equal the background: the uniform block's eigenvalues."""
    p = CASES["vel-stress"] if two_body else Params()
    target = -0.1 - 1.95j if two_body else 0.2 - 7.0j
    same = FrictionProfile(Delta=_patch(p.Delta, p.Delta, 1.0, 2.0),
                           f=_patch(p.f, p.f, 1.0, 2.0), gamma=lambda x: np.full(len(x), p.gamma))
    lams = []
    for friction in (None, same):
        problem, modes = _solve(p, 4.0, 16, 3, None, target, friction=friction)
        lams.append([m.eigenvalue for m in modes])
        _destroy(problem, modes)
    # The same operator: equal to the last bit serially; under 2 ranks the parallel reductions
    # may differ from one solve to the next (measured 0 and ~1e-15 relative in two runs).
    diff = max(abs(a - b) / abs(a) for a, b in zip(*lams, strict=True))
    assert diff <= (0.0 if COMM.size == 1 else 1e-13)


@pytest.mark.parametrize("two_body", [False, True])
def test_patch_rows_carry_their_own_law(two_body):
    """T(Lambda) with a patch = the uniform operator of the background outside the patch and
    the uniform operator of the patch values in its rows (every matrix, every row)."""
    p = CASES["vel-stress"] if two_body else Params()
    inside = dict(Delta=-0.3, f=0.5, gamma=0.7)
    profile = FrictionProfile(**{n: _patch(v, getattr(p, n), 0.9, 2.6)
                                 for n, v in inside.items()})
    strip = strip_mesh_for(COMM, p, 4.0, 16, 3)
    problem = build_strip_problem(strip, p, k=None, degree=2, lateral="roller",
                                  friction=profile)
    patch_op = friction_operator_for(problem)
    problem.friction = None
    outside_op = friction_operator_for(problem)
    problem.params = p.replace(**inside)
    inside_op = friction_operator_for(problem)
    in_rows = problem.interface_x[(problem.interface_coordinate >= 0.9)
                                  & (problem.interface_coordinate <= 2.6)]
    assert COMM.allreduce(len(in_rows)) == 2 * 6 + 1  # P2 nodes at x = 1, 1.125, ..., 2.5
    r0, r1 = patch_op.matrices[0].getOwnershipRange()
    others = np.setdiff1d(np.arange(r0, r1), in_rows).astype(PETSc.IntType)
    for a, out, ins in zip(patch_op.matrices, outside_op.matrices, inside_op.matrices,
                           strict=True):
        d = ins.copy()
        d.axpy(-1.0, out)
        d.zeroRows(others, diag=0.0)  # inside - outside, in the patch rows only
        d.axpy(-1.0, a)
        d.axpy(1.0, out)  # patch - outside - (that): zero
        assert d.norm() <= 1e-14 * max(a.norm(), 1.0)
        d.destroy()
    for op in (patch_op, outside_op, inside_op):
        op.destroy()
    problem.destroy()


@pytest.mark.slow  # measured 20 .. 30 s per case (2026-11-24)
@pytest.mark.serial
@pytest.mark.parametrize("ranks", [1, 2])
def test_mode_shape_scene_two_bodies(tmp_path, ranks):
    """mode_shape.py --mu2 ...: the eigenvalue against the exact two-body root; both bodies."""
    out = tmp_path / "out"
    res = run_workflow("mode_shape.py", ["--out", str(out), *SUBSTRATE, "--cells-per-wavelength",
                                         "8", "--ny", "4", "--no-render", "--phases", "2"],
                       nproc=ranks)
    assert res.returncode == 0, res.stderr[-3000:]
    meta = json.loads((out / "mode.json").read_text())
    exact = _exact(CASES["vel-stress"], 1.0)
    lam = complex(*meta["eigenvalue"])
    # measured 6.97e-4 (P2, 8 x 4 cells per body, grading 1 at k H = 0.5), 1 and 2 ranks: the
    # error of test_bloch_cell_converges_to_the_exact_two_body_root's coarse mesh
    assert abs(lam - exact) / abs(exact) < 1.05 * 6.97e-4
    assert "two bodies" in meta["source"]
    rows = np.loadtxt(out / "interface.csv", delimiter=",", skiprows=1)
    assert rows.shape == (8 + 1, 7)


@pytest.mark.slow  # measured 20 .. 30 s per case (2026-11-24)
@pytest.mark.serial
@pytest.mark.parametrize("ranks", [1, 2])
def test_finite_block_scene_two_bodies(tmp_path, ranks):
    """finite_block.py --mu2 ...: the reference is the exact two-body root at k_inf."""
    out = tmp_path / "out"
    res = run_workflow("finite_block.py", ["--out", str(out), *SUBSTRATE, "--lengths", "4,8",
                                           "--cells-per-unit", "3", "--ny", "3", "--targets",
                                           "2", "--nev", "4", "--k-scan", "0.5:3:6"],
                       nproc=ranks)
    assert res.returncode == 0, res.stderr[-3000:]
    meta = json.loads((out / "finite_block.json").read_text())
    lam_inf = complex(*meta["lambda_inf"])
    root = polish_root(CASES["vel-stress"], meta["k_inf"], lam_inf)
    assert abs(root.value - lam_inf) < 1e-10 * abs(lam_inf)
    assert "kulikovskii" not in meta
    with open(out / "finite_block.csv") as f:
        rows = f.read().splitlines()
    assert len(rows) == 3 and "nan" not in rows[2]


@pytest.mark.serial
@pytest.mark.parametrize("ranks", [1, 2])
def test_finite_block_refuses_a_half_space_substrate(tmp_path, ranks):
    """--mu2 without a finite --H2: one line naming H2, exit code 2, nothing written."""
    out = tmp_path / "never"
    res = run_workflow("finite_block.py", ["--out", str(out), "--mu2", "2"], nproc=ranks)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "H2" in lines[0]
    assert not out.exists()
