"""The certified complete spectrum: forms.solvers.certified / analytic.numerics.spectrum and
workflows/sweep_k.py.

The module-level tests run serially and under mpirun -n 2 (the models live on COMM_SELF, so
every rank must get the same numbers); the scene runs are subprocesses, launched from the serial
pass only (they start their own mpirun where needed).
"""

import csv
import json
import os

import numpy as np
import pytest
from _workflows import run_workflow

from mpi4py import MPI

from analytic import Params, roots_in_box
from analytic.numerics.spectrum import (
    Region,
    certified_roots,
    families,
    fastest_in_box,
    fastest_mode,
)
from analytic.physics.tail import tail_bound, velocity_scale
from forms.solvers.certified import CertifiedSolver, KResult, default_discretisation
from forms.studies import sweep

#: k = 1, branch 0-, paper defaults (docs/design.md section 4).
CHECK_VALUE = 0.2716852879456 - 6.5866951866228j


def _solver(p, region, k_max, solver="moments"):
    deg, cells, ratio = default_discretisation(p, region, k_max, 1e-8)
    return CertifiedSolver(p, region, deg, cells, ratio, k_max, 1e-8, solver=solver)


def _solve_and_match(p, k, region=None):
    """Certified solve at ``k`` and an independent exact search (zeros_in_box on the exact
    determinant) of the same rectangle; returns (result, exact roots, FE values, nearest)."""
    region = region or Region()
    fams = families(p, region, np.array([k]))
    solver = _solver(p, region, k)
    try:
        res = solver.solve(k, fams)
    finally:
        solver.destroy()
    exact = roots_in_box(p, k, res.box)
    fe = np.array([complex(r["re_lambda"], r["im_lambda"]) for r in res.rows])
    ex = np.array([r.value for r in exact])
    nearest = [int(np.argmin(np.abs(ex - z))) for z in fe]
    return res, ex, fe, nearest


@pytest.mark.parametrize("k", [1.0, 3.0])
@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_fe_count_equals_exact_count_and_values_match(bc, k):
    res, ex, fe, nearest = _solve_and_match(Params(H=0.5, bc=bc), k)
    assert res.closed and res.n_fe == res.n_exact == len(ex) == len(res.rows)
    # each FE value matched to a distinct exact root: the nearest-root map is a bijection
    assert sorted(nearest) == list(range(len(ex)))
    # default discretisation for rtol = 1e-8: measured max error 3.3e-9 over the default sweep
    assert np.max(np.abs(fe - ex[nearest]) / np.abs(ex[nearest])) < 1e-8
    assert all(r["status"] == "ok" for r in res.rows)
    assert len({r["label"] for r in res.rows}) == len(res.rows)
    if bc == "velocity" and k == 1.0:
        z = fe[[r["label"] for r in res.rows].index("0-")]
        assert abs(z - CHECK_VALUE) / abs(CHECK_VALUE) < 1e-10


@pytest.mark.parametrize("case", [
    {"mu2": 3.0, "H2": 0.5},
    {"mu2": 0.5, "H2": 0.7, "bc": "stress", "bc2": "stress"},
    {"mu2": 10.0, "rho2": 2.0, "H2": 0.3, "alpha_pc": 0.2},
])
def test_two_body_certified_spectrum(case):
    """Two deformable bodies (layered FE model vs analytic.physics.twobody): counts close, values
    match."""
    p = Params(H=0.5, **case)
    # the slider's 4 c_d, as before the region was scaled by the largest c_d of the stack (in the
    # scaled region, 4 c_d2, case 2 misses rtol: see the branch report)
    res, ex, fe, nearest = _solve_and_match(p, 1.5, Region(c_max=4.0 / (p.beta
                                                                        * velocity_scale(p))))
    assert res.closed and res.n_fe == res.n_exact == len(ex) == len(res.rows) > 0
    assert sorted(nearest) == list(range(len(ex)))
    # measured 2.4e-9 at most (mu2 = 3, k = 0.5..3); the rows must meet rtol = 1e-8
    assert np.max(np.abs(fe - ex[nearest]) / np.abs(ex[nearest])) < 1e-8
    assert all(r["status"] == "ok" for r in res.rows)


def test_count_check_fails_when_a_root_is_removed(monkeypatch):
    """A root taken out of the candidates on purpose: the k must be flagged, every row too."""
    import forms.solvers.certified as fc

    p, region, k = Params(H=0.5), Region(), 3.0
    fams = families(p, region, np.array([k]))

    def drop_one(*args, **kwargs):
        lab, box, n = certified_roots(*args, **kwargs)
        return lab[1:], box, n

    monkeypatch.setattr(fc, "certified_roots", drop_one)
    solver = _solver(p, region, k, "newton")  # the exact-seeded path (FE first: test_fe_first)
    try:
        res = solver.solve(k, fams)
    finally:
        solver.destroy()
    assert not res.closed and res.n_fe == res.n_exact == len(res.rows) + 1
    assert res.rows and all("count not closed" in r["status"] for r in res.rows)


def test_region_holds_the_fastest_mode():
    """Default region: no root outside it (up to 8 c_d) grows faster than the fastest inside."""
    p, region = Params(H=0.5), Region()
    for k in (6.0, 14.0):
        w = region.im_max(p, k)
        inside = roots_in_box(p, k, region.box(p, k))
        wide = roots_in_box(p, k, (region.re_min, region.re_max, -2 * w, 2 * w))
        outside = [r.value.real for r in wide if abs(r.value.imag) > w]
        assert max(r.value.real for r in inside) > max(outside, default=-1.0)


def test_distributed_solve_equals_the_serial_solve_and_resumes(tmp_path):
    """forms.studies.sweep: families and k values shared over the ranks (round robin), saved as
    parts (workflows/_parts.py, as the scene does), read back; equal to the serial solve at
    every k on every rank. A removed part is the only pending k on resume; without resume
    every k is pending again."""
    from _parts import Parts

    comm = MPI.COMM_WORLD
    folder = comm.bcast(str(tmp_path) if comm.rank == 0 else None)
    parts = Parts(os.path.join(folder, "raw"), "k{:05d}")
    p, region, k = Params(H=0.5), Region(), np.array([0.5, 1.5, 2.5])

    def pending(resumed):
        return parts.begin(comm, resumed, count=len(k)).todo

    todo = pending(resumed=False)
    assert todo == [0, 1, 2]
    plan, items = sweep.family_plan(comm, p, region, float(k[-1]))
    fams = sweep.follow_families(comm, p, region, plan, items, k,
                                 list(range(comm.rank, len(items), comm.size)))
    assert [f.label for f in fams] == [f.label for f in families(p, region, k)]
    mine = todo[comm.rank::comm.size]
    calls = []
    rungs = sweep.RungSolvers(p, region, float(k[-1]), 1e-8, (0, 0, 0.0))
    share = sweep.solve_k_values(p, region, rungs, k, mine, fams, parts.save,
                                 lambda: calls.append(1))
    assert share.k_values == len(mine) == len(calls) and share.unknowns > 0
    comm.Barrier()
    results = [sweep.k_result_from_json(d) for d in parts.load_all().values()]
    serial = []
    for kk in k:  # each k on the mesh the sweep plans for it (RungSolvers.mesh_k)
        disc = rungs.discretisation(region.c_max, float(kk))
        solver = CertifiedSolver(p, region, *disc, rungs.mesh_k(float(kk)), 1e-8)
        try:
            serial.append(solver.solve(float(kk), fams))
        finally:
            solver.destroy()
    for a, b in zip(results, serial, strict=True):
        assert a.k == b.k and a.closed and b.closed and a.n_fe == b.n_fe
        assert [r["label"] for r in a.rows] == [r["label"] for r in b.rows]
        for ra, rb in zip(a.rows, b.rows, strict=True):
            # the same computation on another rank (same Newton starts): measured identical
            z = complex(rb["re_lambda"], rb["im_lambda"])
            assert abs(complex(ra["re_lambda"], ra["im_lambda"]) - z) <= 1e-12 * abs(z)
    comm.Barrier()
    if comm.rank == 0:
        os.remove(os.path.join(folder, "raw", "k00001.json"))
    assert pending(resumed=True) == [1]
    assert pending(resumed=False) == [0, 1, 2]


@pytest.mark.serial
@pytest.mark.parametrize("bc", ["stress", "velocity"])
def test_exact_rungs_warm_started_equal_the_cold_climbs(bc):
    """sweep.regions_at_k (the exact referee's rung per k) starts each k's search from the
    last k's fastest root and located roots and does not count the whole region: the same rung
    at every k as fastest_mode from scratch (its default, every root counted), and as the
    whole-region count says (the fastest root's rung: the tail bound below it)."""
    p, region = Params(bc=bc), Region(c_max=None)
    k = np.linspace(0.05, 6.0, 25)
    warm, _ = sweep.regions_at_k(p, region, k, True,
                                 lambda costs, fn: [fn(i) for i in range(len(costs))])
    cold = [fastest_mode(p, float(x), region) for x in k]
    assert warm == [m.c_max for m in cold]
    assert all(m.proven for m in cold if m.root is not None)
    assert len(set(warm)) >= (3 if bc == "stress" else 1)  # the stress top climbs (8-32 c_d)


@pytest.mark.serial
@pytest.mark.parametrize("bc", ["stress", "velocity"])
def test_families_followed_per_k_region_give_the_tall_regions_roots(bc):
    """sweep.follow_all follows each family only where it may lie in the region of that k (the
    adaptive region's bound per k, plan.c_at_k): at every k its values inside that k's box are
    the values of the families followed in the tallest box at every k (the old plan), as many
    as the exact count in the box, every root labelled as the old plan labels it."""
    p, region = Params(bc=bc), Region(c_max=None)
    k = np.linspace(0.05, 6.0, 9)
    plan = sweep.plan_regions(p, region, k, True, "linear",
                              lambda costs, fn: [fn(i) for i in range(len(costs))])
    comm = MPI.COMM_SELF
    per_k = sweep.follow_all(comm, p, plan, region, k, range)
    fplan, items = sweep.family_plan(comm, p, plan.big, float(k[-1]))
    tall = sweep.follow_families(comm, p, plan.big, fplan, items, k, range(len(items)))
    assert [f.label for f in per_k] == [f.label for f in tall]
    for i, kk in enumerate(k):
        box = region.fixed(plan.c_at_k[i]).box(p, float(kk))

        def inside(fams, i=i, box=box):
            return sorted((f.label, complex(f.Lambda[i])) for f in fams
                          if np.isfinite(f.Lambda[i]) and box[0] <= f.Lambda[i].real <= box[1]
                          and box[2] <= f.Lambda[i].imag <= box[3])

        a, b = inside(per_k), inside(tall)
        assert [x[0] for x in a] == [x[0] for x in b]
        # the same roots by other continuation paths: measured 2.2e-16 relative at most
        assert all(abs(x[1] - y[1]) <= 1e-12 * abs(y[1]) for x, y in zip(a, b, strict=True))
        reg = region.fixed(plan.c_at_k[i])
        got, _, n = certified_roots(p, float(kk), reg, per_k)
        want, _, _ = certified_roots(p, float(kk), reg, tall)
        assert n == len(got) and all(not r.label.startswith("?") for r in got)
        assert [(r.label, r.certified) for r in got] == [(r.label, r.certified) for r in want]


def _row(k, re, status="ok", err=1e-10, est=2e-10):
    return {"k": k, "label": f"L{re}", "re_lambda": re, "im_lambda": -1.0,
            "re_lambda_exact": re, "im_lambda_exact": -1.0, "rel_error": err,
            "error_estimate": est, "residual": 0.0, "status": status}


@pytest.mark.serial
@pytest.mark.parametrize("closed", [True, False])
@pytest.mark.parametrize("best_status", ["ok", "error 1e-06 > rtol"])
def test_summary_counts_and_most_unstable(closed, best_status):
    """forms.studies.sweep.summarise on hand-made results: counts, accuracy, the largest Re Lambda
    and
    its certificate (certified only if its row is ok and every k closed)."""
    p, region, k = Params(H=0.5), Region(), np.array([1.0, 2.0])
    results = [KResult(1.0, [_row(1.0, -0.5), _row(1.0, 0.1, est=float("nan"))], 2, 2,
                       (-1.0, 2.0, -9.0, 9.0), True),
               KResult(2.0, [_row(2.0, 0.3, best_status, err=3e-9)], 1, 1 if closed else 2,
                       (-1.0, 2.0, -12.0, 12.0), closed, "" if closed else "not closed")]
    s = sweep.summarise(p, region, k, results, [])
    cert = s["certificate"]
    assert (cert["k_values"], cert["k_closed"], cert["rows"]) == (2, 1 + closed, 3)
    assert cert["rows_ok"] == 2 + (best_status == "ok")
    assert [r["k"] for r in cert["k_not_closed"]] == ([] if closed else [2.0])
    assert s["accuracy"] == {"max_rel_error_vs_exact": 3e-9, "max_error_estimate": 2e-10}
    best = s["most_unstable"]
    assert (best["k"], best["re_lambda"], best["branch"]) == (2.0, 0.3, "L0.3")
    assert best["at_edge_of_k_range"] and best["certificate"]["count_at_k"] == 1
    assert best["certificate"]["region_at_k"] == [-1.0, 2.0, -12.0, 12.0]
    assert best["certificate"]["certified"] == (closed and best_status == "ok")
    assert [d["k"] for d in s["per_k"]] == [1.0, 2.0]
    assert sweep.summarise(p, region, k, [KResult(1.0), KResult(2.0)], [])[
        "most_unstable"] is None
    # the region proof per k: the tail bound at W(k) of the 4 c_d region, against the fastest row
    tb = [tail_bound(p, kk, region.im_max(p, kk)) for kk in k]
    assert [d["tail_bound"] for d in s["per_k"]] == tb and [d["c_max"] for d in s["per_k"]] == [
        4.0, 4.0]
    assert [d["fastest_proven"] for d in s["per_k"]] == [tb[0] < 0.1, tb[1] < 0.3]
    assert best["certificate"]["largest_tail_bound"] == max(tb)
    assert best["certificate"]["fastest_mode"] == (max(tb) < 0.3)
    # an adaptive region's per-k bounds are reported as given
    s2 = sweep.summarise(p, Region(c_max=None), k, results, [], [4.0, 8.0])
    assert [d["c_max"] for d in s2["per_k"]] == [4.0, 8.0]
    assert s2["per_k"][1]["tail_bound"] == tail_bound(p, 2.0, Region(c_max=8.0).im_max(p, 2.0))
    assert s2["region"]["c_max"] == "auto"


# ------------------------------------------------------------------- the scene (subprocesses)
QUIET = ["--quiet", "--no-plot"]


def _rows(out):
    with open(os.path.join(out, "spectrum.csv")) as fh:
        return list(csv.DictReader(fh))


def _by_k(rows):
    d = {}
    for r in rows:
        d.setdefault(float(r["k"]), {})[r["label"]] = complex(float(r["re_lambda"]),
                                                              float(r["im_lambda"]))
    return d


@pytest.mark.slow  # measured 13-32 s on the loaded 2-core machine
@pytest.mark.serial
def test_sparse_and_dense_k_lists_give_the_same_labels_and_values(tmp_path):
    sparse, dense = tmp_path / "sparse", tmp_path / "dense"
    for out, ks in ((sparse, "1,3,5"), (dense, "1:5:17")):
        proc = run_workflow("sweep_k.py", ["--k", ks, *QUIET, "--out", str(out)])
        assert proc.returncode == 0, proc.stderr[-2000:]
    s, d = _by_k(_rows(sparse)), _by_k(_rows(dense))
    for k in (1.0, 3.0, 5.0):
        assert set(s[k]) == set(d[k])
        for lab, z in s[k].items():
            # same exact root, same Newton start: only rounding differs (measured 1e-15)
            assert abs(z - d[k][lab]) <= 1e-12 * abs(z)
    assert "s0+" in s[3.0]  # the family near 4.3i at k = 3 (not a waveguide branch)


@pytest.mark.serial
def test_duplicate_k_values_are_merged(tmp_path):
    out = tmp_path / "dup"
    proc = run_workflow("sweep_k.py", ["--k", "0.5,1,1,2", "--out", str(out), "--no-plot"])
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "1 duplicate k value(s) merged" in proc.stderr
    rows = _rows(out)
    assert sorted({float(r["k"]) for r in rows}) == [0.5, 1.0, 2.0]
    assert all(r["status"] == "ok" for r in rows)
    labels_at_1 = [r["label"] for r in rows if float(r["k"]) == 1.0]
    assert len(labels_at_1) == len(set(labels_at_1))


@pytest.mark.slow  # measured 13-32 s on the loaded 2-core machine
@pytest.mark.serial
def test_large_k_no_duplicated_root_and_every_exact_root_reported(tmp_path):
    """--k 50,51 (the stable roots of the issue, -0.19999+100.746i and -0.8212+102.820i, are
    inside this region): each exact root once, no two rows on one root."""
    out = tmp_path / "k50"
    proc = run_workflow("sweep_k.py", ["--k", "50,51", "--re-min", "-0.9", "--c-max", "1",
                                       *QUIET, "--out", str(out)], timeout=900)
    assert proc.returncode in (0, 1), proc.stderr[-2000:]
    rows = _rows(out)
    summary = json.loads((out / "summary.json").read_text())
    p = Params(H=0.5)
    for item in summary["per_k"]:
        k = item["k"]
        assert item["closed"], item
        mine = [r for r in rows if float(r["k"]) == k]
        fe = np.array([complex(float(r["re_lambda"]), float(r["im_lambda"])) for r in mine])
        exact = np.array([r.value for r in roots_in_box(p, k, tuple(item["box"]))])
        assert len(fe) == len(exact) == item["n_exact"] == item["n_fe"]
        d = np.abs(fe[:, None] - exact[None, :])
        assert sorted(np.argmin(d, axis=1)) == list(range(len(exact)))  # distinct matches
        assert len({r["label"] for r in mine}) == len(mine)
    at50 = _by_k(rows)[50.0]
    for z in (-0.19999 + 100.746j, -0.8212 + 102.820j):
        assert min(abs(v - z) for v in at50.values()) < 1e-3


@pytest.mark.slow  # measured 13-32 s on the loaded 2-core machine
@pytest.mark.serial
def test_alpha_pc_2_branch_0plus_followed_through_its_brief_instability(tmp_path):
    out = tmp_path / "apc"
    proc = run_workflow("sweep_k.py", ["--alpha-pc", "2", "--k", "4.0:4.2:21", *QUIET,
                                       "--out", str(out)])
    everything = _rows(out)
    # a genuine near-collision elsewhere (s1- with 0-, k = 4.14) is flagged and stays flagged;
    # the exit code says so
    flagged = [r for r in everything if r["status"] != "ok"]
    assert proc.returncode == (1 if flagged else 0), proc.stderr[-2000:]
    assert all("label not certified" in r["status"] for r in flagged)
    rows = [r for r in everything if r["label"] == "0+"]
    assert len(rows) == 21 and all(r["status"] == "ok" for r in rows)
    re = np.array([float(r["re_lambda"]) for r in rows])
    assert re.max() > 0 and re[0] < 0 and re[-1] < 0  # unstable in between, stable at the ends
    p = Params(H=0.5, alpha_pc=2.0)
    for r in rows[::5]:
        z = complex(float(r["re_lambda"]), float(r["im_lambda"]))
        ex = roots_in_box(p, float(r["k"]), (z.real - 1e-3, z.real + 1e-3, z.imag - 1e-3,
                                             z.imag + 1e-3))
        assert len(ex) == 1 and abs(ex[0].value - z) < 1e-8 * abs(z)


@pytest.mark.slow  # velocity 34 s, stress 5 min (region up to 24 c_d), loaded 2-core machine
@pytest.mark.serial
@pytest.mark.parametrize("bc", ["velocity", "stress"])
def test_most_unstable_is_the_maximum_of_the_exact_roots(tmp_path, bc):
    out = tmp_path / bc
    # stress: 242 s serial on the idle machine (2026-11-24), over 300 s in the suite's two
    # workers: the subprocess gets 900 s
    proc = run_workflow("sweep_k.py", ["--bc", bc, "--k", "0.5:6:12", *QUIET, "--out",
                                       str(out)], timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    best = summary["most_unstable"]
    # independent: the fastest exact root of a wider fixed region (48 c_d, beyond any bound used
    # here: the stress top climbs to 24 c_d at some k), by the argument principle on det_M
    # (fastest_in_box: the box counted, a band below re_max narrowed by counts and its roots
    # located; equal to locating every root, tests/test_spectrum_fastest.py)
    p, region = Params(H=0.5, bc=bc), Region(c_max=48.0)
    assert max(d["c_max"] for d in summary["per_k"]) < 48.0
    exact = [(k, fastest_in_box(p, k, region.box(p, k))[0]) for k in np.linspace(0.5, 6, 12)]
    k_ex, z_ex = max(exact, key=lambda t: t[1].real)
    assert best["k"] == pytest.approx(k_ex, rel=1e-12)
    assert abs(complex(best["re_lambda"], best["im_lambda"]) - z_ex) < 1e-8 * abs(z_ex)
    assert best["certificate"]["certified"] and best["status"] == "ok"
    assert best["certificate"]["fastest_mode"]


@pytest.mark.serial
@pytest.mark.parametrize("alpha_pc, proven", [(0.0, True), (1.0, False)])
def test_result_line_says_when_r_is_not_proven_to_hold_the_fastest_mode(tmp_path, alpha_pc,
                                                                        proven):
    """Stress top: with alpha_pc = 1 the hybridised-pair bound (analytic.physics.tail) is far
    above the roots (the fastest at k = 2, 8 near 0.006 and 0.0008), so the region is not proven
    to hold the fastest mode: the printed "most unstable" is the largest in R only, and the line
    says so (it used to read "certified" alone)."""
    out = tmp_path / "o"
    proc = run_workflow("sweep_k.py", ["--bc", "stress", "--alpha-pc", str(alpha_pc), "--k",
                                       "2,8", "--check-exact", "no", *QUIET, "--out",
                                       str(out)])
    assert proc.returncode == 0, proc.stderr[-2000:]
    cert = json.loads((out / "summary.json").read_text())["most_unstable"]["certificate"]
    assert cert["fastest_mode"] is proven and cert["certified"]
    line = next(x for x in proc.stdout.splitlines() if x.startswith("most unstable"))
    assert ("R not proven to hold the fastest mode" in line) is not proven


@pytest.mark.slow  # 12 s of CPU, measured 138 s wall on the loaded 2-core machine
@pytest.mark.serial
def test_most_unstable_is_the_fastest_mode_far_beyond_4_c_d(tmp_path):
    """Stress top, beta = 0.6, gamma = 1, k = 4: the fastest mode runs at 11.8 c_d. The sweep's
    adaptive region grows until the tail bound proves it; an independent exact search of a
    wider fixed region (48 c_d) finds the same fastest root."""
    out = tmp_path / "far"
    proc = run_workflow("sweep_k.py", ["--bc", "stress", "--beta", "0.6", "--gamma", "1",
                                       "--k", "4", *QUIET, "--out", str(out)])
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    best = summary["most_unstable"]
    z = complex(best["re_lambda"], best["im_lambda"])
    p = Params(H=0.5, bc="stress", beta=0.6, gamma=1.0)
    region = Region(c_max=48.0)
    w = region.im_max(p, 4.0)
    # the fastest root is above Re = 0.05 (the box's lower edge keeps the search cheap)
    exact = roots_in_box(p, 4.0, (0.05, 2.0, -w, w))
    z_ex = max((r.value for r in exact), key=lambda v: v.real)
    assert abs(z - z_ex) < 1e-8 * abs(z_ex)  # the sweep's rtol
    assert abs(z.imag) * p.beta / 4.0 > 10.0  # phase velocity in units of c_d
    cert = best["certificate"]
    assert cert["fastest_mode"] and cert["certified"] and cert["largest_tail_bound"] < z.real
    assert summary["per_k"][0]["c_max"] > 4.0


@pytest.mark.serial
@pytest.mark.parametrize("check_exact", ["yes", "no"])
def test_most_unstable_at_k_26_5_is_the_fastest_mode_beyond_4_c_d(tmp_path, check_exact):
    """Issue 17's case through the sweep: paper defaults, stress top, k = 26.5. The fixed 4 c_d
    region's fastest root is 0.2961604; the sweep's region climbs until the tail bound proves
    it holds the fastest mode, 0.3170864 at 4.50 c_d, with the exact check and with the FE
    alone (--check-exact no). Independent: the fastest exact root of a box 32 c_d tall (twice
    the rung the sweep climbs to) and of the 4 c_d box, by the argument principle on det_M."""
    out = tmp_path / check_exact
    proc = run_workflow("sweep_k.py", ["--bc", "stress", "--k", "26.5", "--check-exact",
                                       check_exact, *QUIET, "--out", str(out)])
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    best = summary["most_unstable"]
    z = complex(best["re_lambda"], best["im_lambda"])
    p, k = Params(H=0.5, bc="stress"), 26.5
    assert summary["per_k"][0]["c_max"] < 32.0
    z_ex = fastest_in_box(p, k, Region(c_max=32.0).box(p, k))[0]
    z4 = fastest_in_box(p, k, Region(c_max=4.0).box(p, k))[0]
    assert abs(z - z_ex) < 1e-8 * abs(z_ex)  # the sweep's rtol (measured 5.5e-15 both ways)
    assert z.real == pytest.approx(0.3170864, abs=5e-8) and z4.real < z.real - 0.02
    assert abs(z.imag) * p.beta / k > 4.0  # phase velocity beyond 4 c_d
    cert = best["certificate"]
    assert cert["fastest_mode"] and cert["certified"] and cert["largest_tail_bound"] < z.real
    assert cert["carries"] == ("fe+exact" if check_exact == "yes" else "fe")


@pytest.mark.serial
def test_two_body_stiff_substrate_most_unstable_is_the_fastest_mode(tmp_path):
    """Issue 17's two-body case through the sweep, FE alone (--check-exact no): mu2 = 4 (c_d2 =
    2 c_d of the slider), velocity top, k = 5. The region is scaled by the stack's largest c_d
    and climbs to 6 c_d2, where the stack's tail bound proves the most unstable mode, at 6.9 c_d
    of the slider. Independent: the fastest root of det_twobody in a box twice as tall as the
    region's, by zeros_in_box."""
    from analytic.numerics.branches import _n_initial, spectrum_function
    from analytic.numerics.roots import zeros_in_box

    out = tmp_path / "two"
    proc = run_workflow("sweep_k.py", ["--mu2", "4", "--rho2", "1", "--H2", "0.5", "--k", "5",
                                       "--check-exact", "no", *QUIET, "--out", str(out)])
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    best, row = summary["most_unstable"], summary["per_k"][0]
    z = complex(best["re_lambda"], best["im_lambda"])
    p, k = Params(H=0.5, mu2=4.0, rho2=1.0, H2=0.5), 5.0
    assert row["c_max"] > 4.0  # the rung, in units of c_d2 (the first, 4, does not prove)
    assert abs(z.imag) * p.beta / k > 4.0  # 6.9 c_d of the slider: outside its old 4 c_d box
    cert = best["certificate"]
    assert cert["fastest_mode"] and cert["certified"] and cert["largest_tail_bound"] < z.real
    fun = spectrum_function(p, k)
    w = 2.0 * row["box"][3]
    faster = []
    for box in ((z.real - 0.02, 2.0, -w, 0.0), (z.real - 0.02, 2.0, 0.0, w)):
        faster += [r.value for r in zeros_in_box(fun, box, n_initial=_n_initial(p, box))]
    z_ex = max(faster, key=lambda v: v.real)
    assert abs(z - z_ex) < 1e-8 * abs(z_ex)  # the sweep's rtol (measured 6.0e-14)


@pytest.mark.slow  # measured 13-32 s on the loaded 2-core machine
@pytest.mark.serial
def test_two_ranks_give_the_same_spectrum_and_plot(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    proc = run_workflow("sweep_k.py", ["--k", "0.5,2,4", "--quiet", "--out", str(one)])
    assert proc.returncode == 0, proc.stderr[-2000:]
    proc = run_workflow("sweep_k.py", ["--k", "0.5,2,4", "--quiet", "--out", str(two)], nproc=2)
    assert proc.returncode == 0, proc.stderr[-2000:]
    a, b = _rows(one), _rows(two)
    assert [r["label"] for r in a] == [r["label"] for r in b]
    for ra, rb in zip(a, b, strict=True):
        assert float(ra["re_lambda"]) == pytest.approx(float(rb["re_lambda"]), abs=1e-12)
        assert float(ra["im_lambda"]) == pytest.approx(float(rb["im_lambda"]), abs=1e-11)
    assert json.loads((two / "summary.json").read_text())["mpi"]["ranks"] == 2
    assert (two / "dispersion.png").stat().st_size > 10000
    for run in (one, two):  # rank 0's post-processing includes the picture's early import
        t = json.loads((run / "summary.json").read_text())["timing_s"]
        assert 0 < t["matplotlib_import_rank0"] <= t["post_processing_rank0"] < t["wall"]
        assert 0 < t["serial_tail"] < t["wall"]


@pytest.mark.serial
@pytest.mark.parametrize("nproc", [1, 2])
@pytest.mark.parametrize("bad, word", [(["--re-min", "-2"], "re-min"), (["--rtol", "0"], "rtol"),
                                       (["--H", "inf"], "H"), (["-beta", "0.8"], "-beta"),
                                       (["--be", "0.6"], "--be"),
                                       (["--mu2", "3"], "H2"), (["--c-max", "fast"], "c-max"),
                                       (["--c-max", "-1"], "c-max"),
                                       # P1 at rtol 1e-8: 108 642 unknowns at k = 6 (the cells
                                       # rule), above SECTION_UNKNOWNS_MAX
                                       (["--degree", "1"], "--degree = 1")])
def test_bad_input_one_line_exit_2_nothing_written(tmp_path, bad, word, nproc):
    out = tmp_path / "bad"
    proc = run_workflow("sweep_k.py", [*bad, "--out", str(out)], nproc=nproc)
    assert proc.returncode == 2
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and word in lines[0], proc.stderr
    assert not out.exists()


@pytest.mark.serial
def test_resume_continues_and_refuses_other_parameters(tmp_path):
    out = tmp_path / "r"
    proc = run_workflow("sweep_k.py", ["--k", "0.5,1", *QUIET, "--out", str(out)])
    assert proc.returncode == 0
    os.remove(out / "raw" / "k00001.json")
    proc = run_workflow("sweep_k.py", ["--k", "0.5,1", *QUIET, "--out", str(out), "--resume"])
    assert proc.returncode == 0, proc.stderr
    assert json.loads((out / "summary.json").read_text())["computed_this_run"] == 1
    proc = run_workflow("sweep_k.py", ["--k", "0.5,1", "--beta", "0.45", *QUIET, "--out",
                                       str(out), "--resume"])
    assert proc.returncode == 2 and "beta" in proc.stderr
