"""Half-space modes with a PML layer (forms/models/pml.py) against the roots of s(z, q).

Runs serially and under ``mpirun -n 2 python -m mpi4py -m pytest`` (``world``: one mesh
distributed over both ranks; ``self``: one mesh per rank).
"""

import cmath
import logging
import math

import numpy as np
import pytest

from mpi4py import MPI

from analytic.params import Params
from analytic.physics import largek
from analytic.physics.halfspace import dilatational_root, shear_root
from forms.models.pml import (
    classify_sheet,
    design_layer,
    solve_halfspace,
    solve_truncated,
    wavenumbers,
)

logging.disable(logging.INFO)
COMMS = {"world": MPI.COMM_WORLD, "self": MPI.COMM_SELF}


def _p(gamma: float, delta: float) -> Params:
    return Params(gamma=gamma, Delta=delta, H=math.inf)


@pytest.mark.parametrize("comm_name", ["world", "self"])
@pytest.mark.parametrize("q,gamma,delta", [(0.3, 3.0, 0.7), (1.0, 4.0, 0.7), (0.5, 3.0, 0.5)])
def test_dilatational_roots_well_above_threshold(q, gamma, delta, comm_name):
    """FE + PML, started from the paper's closed form (Eq. kappa_d1), vs the exact root."""
    p = _p(gamma, delta)
    exact = dilatational_root(q, p)
    assert exact.sheet == "physical" and exact.converged
    target = complex(-1j * q * largek.z_linear(q, p))  # closed form, not the exact root
    res = solve_halfspace(COMMS[comm_name], p, q, target, degree=4)
    assert res.ok, res.flags
    assert res.sheet == "physical"
    # measured 5.4e-14 .. 1.3e-13 (P4, default layer, 2026-11-21).
    assert abs(res.Lambda - exact.Lambda) / abs(exact.Lambda) < 1e-12
    # the growth rate is ~1e-4 |Lambda| here: measured relative error 2.7e-10 .. 3.3e-10.
    assert abs(res.Lambda.real - exact.Lambda.real) / abs(exact.Lambda.real) < 3e-9
    # the second layer setting agrees (measured 1e-13 .. 2.2e-13).
    assert res.disagreement < 2e-12


@pytest.mark.parametrize("q", [0.234, 0.3])
def test_shear_roots(q):
    """Shear family near z = -1 (paper Fig. both: gamma = 0.25, Delta = 0.01 < Delta_m)."""
    p = _p(0.25, 0.01)
    exact = shear_root(q, p)
    assert exact.sheet == "physical"
    res = solve_halfspace(MPI.COMM_SELF, p, q, exact.Lambda, degree=4)
    assert res.ok, res.flags
    # measured 7.5e-11 (q = 0.234) and 3.0e-10 (q = 0.3), P4, 2026-11-21.
    assert abs(res.Lambda - exact.Lambda) / abs(exact.Lambda) < 2e-9


def test_root_past_qc_is_the_s_tilde_root():
    """Past q_c (0.707 at the defaults) the continued root is a root of s~ (App. C): the PML
    with the outgoing stretch finds it and says so."""
    p = _p(3.0, 0.7)
    exact = dilatational_root(1.0, p)
    assert exact.sheet == "s_tilde"
    res = solve_halfspace(MPI.COMM_SELF, p, 1.0, exact.Lambda, degree=4, sheet="s_tilde")
    assert res.ok, res.flags
    assert res.sheet == "s_tilde"
    # measured 1.2e-14 (P4, 2026-11-21).
    assert abs(res.Lambda - exact.Lambda) / abs(exact.Lambda) < 1e-12


@pytest.mark.parametrize("q,gamma_f", [(1e-5, 0.7 + 1e-10), (1e-5, 0.7 + 1e-9)])
def test_near_threshold_failure_is_flagged(q, gamma_f):
    """At Gamma - 0.7 ~ 1e-10 the root sits ~1e-16 |Lambda| from the branch point
    z = 1/beta: Re Lambda is below the eigensolver's resolution. The code must say so."""
    p = _p(gamma_f / 0.3, 0.7)
    exact = dilatational_root(q, p)
    res = solve_halfspace(MPI.COMM_SELF, p, q, exact.Lambda, degree=4, sheet=exact.sheet)
    growth_err = abs(res.Lambda.real - exact.Lambda.real) / abs(exact.Lambda.real)
    # measured growth errors 1.8 and 0.24 (2026-11-21): the growth rate is wrong ...
    assert growth_err > 1e-3
    # ... and flagged, not returned quietly.
    assert "growth_unresolved" in res.flags and not res.ok
    # |Lambda| itself is still right (measured 1.7e-16): only the growth rate is lost.
    assert abs(res.Lambda - exact.Lambda) / abs(exact.Lambda) < 1e-12


@pytest.mark.parametrize("attenuation", [1.0, 2.0])
def test_too_weak_layer_is_flagged(attenuation):
    """A layer with 1-2 e-folds reflects: wrong by 3e-5 / 4e-6 (measured), and flagged."""
    p = _p(3.0, 0.7)
    exact = dilatational_root(0.3, p)
    res = solve_halfspace(MPI.COMM_SELF, p, 0.3, exact.Lambda, degree=4,
                          attenuation=attenuation)
    assert abs(res.Lambda - exact.Lambda) / abs(exact.Lambda) > 1e-6
    assert "layer_sensitive" in res.flags


@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_plain_truncation_fails_and_is_flagged(bc):
    """A strip of H = 100 (kH = 30): the radiated shear wave decays over 1/Re k_s ~ 7000,
    so the strip's eigenvalue is not the half-space root (measured errors 1.4e-3, 1.5e-3)."""
    p = _p(3.0, 0.7)
    exact = dilatational_root(0.3, p)
    t = solve_truncated(MPI.COMM_SELF, p, 0.3, 100.0, bc, exact.Lambda, degree=3)
    assert abs(t.Lambda - exact.Lambda) / abs(exact.Lambda) > 1e-4
    assert "reflection" in t.flags
    assert t.reflection > 0.5  # exp(-2 H Re k_s) = 0.97 here


@pytest.mark.parametrize("q,gamma,delta,family", [(0.3, 3.0, 0.7, "d"), (0.3, 0.25, 0.01, "s"),
                                                  (1.0, 3.0, 0.7, "d")])
def test_layer_design_damps_both_waves(q, gamma, delta, family):
    """The bisector angle gives both partial waves the same margin and the wanted e-folds."""
    p = _p(gamma, delta)
    root = dilatational_root(q, p) if family == "d" else shear_root(q, p)
    sheet = root.sheet
    d = design_layer(q, root.Lambda, p.beta, 4, attenuation=16.0, sheet=sheet)
    ks, kd = wavenumbers(root.Lambda, q, p.beta, sheet)
    s = d.stretch
    re_s, re_d = (ks * s).real / abs(ks * s), (kd * s).real / abs(kd * s)
    assert re_s > 0 and re_d > 0
    assert re_s == pytest.approx(re_d, rel=1e-12) and re_s == pytest.approx(d.margin, rel=1e-12)
    assert d.achieved_attenuation(root.Lambda, p.beta) == pytest.approx(16.0, rel=1e-9)
    assert classify_sheet(root.Lambda, q, p.beta, s) == sheet
    assert np.all(np.diff(d.vertices) > 0) and d.top == pytest.approx(2.0 * d.h_phys)
    assert cmath.phase(s) == pytest.approx(d.phi)


# ------------------------------------------------------------ forms/studies/halfspace_modes.py
@pytest.mark.parametrize("comm_name", ["world", "self"])
@pytest.mark.parametrize("q,sheet", [(0.3, "physical"), (1.0, "s_tilde")])
def test_solve_k_rows(q, sheet, comm_name):
    """The rows of one k as halfspace_modes.py writes them: PML trusted and right, a short
    plain strip flagged and wrong."""
    from forms.studies.halfspace_modes import COLUMNS, solve_k

    p = _p(3.0, 0.7)
    root = dilatational_root(q, p)
    assert root.sheet == sheet
    rows = solve_k(COMMS[comm_name], p, root, "dilatational", degree=3, attenuation=16.0,
                   tol=1e-8, heights=[50.0], bcs=["velocity"])
    assert [(r["method"], r["bc"], r["H"]) for r in rows] == [("pml", "", math.inf),
                                                              ("truncated", "velocity", 50.0)]
    pml, strip = rows
    for r in rows:
        assert tuple(sorted(r)) == tuple(sorted(COLUMNS)) and r["k"] == q
        lam = complex(r["re_lambda"], r["im_lambda"])
        assert r["rel_error"] == pytest.approx(abs(lam - root.Lambda) / abs(root.Lambda))
    assert pml["trusted"] and pml["flags"] == "" and pml["sheet"] == sheet
    # P3 layer: measured 4.0e-12 (k = 0.3) and 1.1e-12 (k = 1.0), 2026-11-22.
    assert pml["rel_error"] < 2e-11
    # H = 50 reflects (measured errors 3.7e-3, 4.7e-4): flagged.
    assert not strip["trusted"] and "reflection" in strip["flags"] and strip["rel_error"] > 1e-5


@pytest.mark.serial
@pytest.mark.parametrize("silent_rtol", [1e-6, 1e-3])
def test_silent_failures_and_summary(silent_rtol):
    from forms.studies.halfspace_modes import failure_summary, merge_rows, silent_failures

    def row(k, method, trusted, err, H=math.inf):  # noqa: N803
        return {"k": k, "branch": "unstable", "method": method, "bc": "", "H": H,
                "trusted": trusted, "rel_error": err}

    parts = [[row(0.5, "pml", True, 1e-4), row(0.1, "truncated", False, 1e-2, 50.0)],
             [row(0.1, "pml", True, 1e-12), row(0.2, "pml", False, math.inf)]]
    rows = merge_rows(parts)
    assert [(r["k"], r["method"]) for r in rows] == [(0.1, "pml"), (0.1, "truncated"),
                                                     (0.2, "pml"), (0.5, "pml")]
    silent = silent_failures(rows, silent_rtol)
    assert [r["k"] for r in silent] == ([0.5] if silent_rtol < 1e-4 else [])
    s = failure_summary(rows, silent)
    assert (s["rows"], s["trusted"], s["flagged"], s["silent_failures"]) == (4, 2, 2, len(silent))
    assert s["pml_max_rel_error_trusted"] == 1e-4
    assert [r["k"] for r in s["silent_failure_rows"]] == [r["k"] for r in silent]
