"""Smoke tests of workflows/envelope.py and workflows/contrast.py (serial and mpirun -n 2),
checked against the exact roots they are built on; direct tests of analytic.studies.growth."""

import csv
import json
import os

import numpy as np
import pytest
from _workflows import run_workflow

from analytic import Params, roots_in_box
from analytic.numerics.branches import polish_root
from analytic.numerics.spectrum import Region, fastest_mode, fastest_root
from analytic.studies.growth import (
    best_over_k,
    curve_shape,
    envelope_maximum,
    extremum_midpoints,
    local_extrema,
    plateau_dependence,
)

pytestmark = pytest.mark.serial  # subprocesses (their own mpirun) and pure numpy


@pytest.mark.parametrize("nproc", [1, 2])
def test_envelope_is_the_fastest_exact_root(tmp_path, nproc):
    out = tmp_path / "env"
    proc = run_workflow("envelope.py", ["--k", "1,3,6", "--refine-rounds", "0", "--out",
                                        str(out)], nproc=nproc)
    assert proc.returncode == 0, proc.stderr[-2000:]
    with open(out / "envelope.csv") as fh:
        rows = list(csv.DictReader(fh))
    p, region = Params(), Region()
    for r in rows:
        k = float(r["k"])
        exact = max(z.value.real for z in roots_in_box(p, k, region.box(p, k)))
        assert float(r["re_lambda_max"]) == pytest.approx(exact, rel=1e-10)
    s = json.loads((out / "summary.json").read_text())
    best = s["global_max_on_grid"]
    assert best["re_lambda"] >= max(float(r["re_lambda_max"]) for r in rows)
    assert (out / "envelope.png").stat().st_size > 10000
    # paper defaults, 4 c_d: the tail bound proves the region at k = 1, 3, 6, and the line says so
    for r in rows:
        assert r["fastest_proven"] == str(int(fastest_mode(p, float(r["k"]), region).proven))
    assert [r["fastest_proven"] for r in rows] == ["1", "1", "1"]
    assert s["fastest_proven"]["proven_k"] == s["fastest_proven"]["k_with_root"] == 3
    assert "R proven to hold the fastest mode at all 3 k with a root" in proc.stdout


def _envelope_at_1_and_3(tmp_path, args):
    """envelope.py with ``args`` at k = 1, 3, no refinement: (process, summary, folder)."""
    out = tmp_path / "env"
    proc = run_workflow("envelope.py", [*args, "--k", "1,3", "--refine-rounds", "0", "--out",
                                        str(out)])
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc, json.loads((out / "summary.json").read_text()), out


def test_envelope_says_in_r_only_where_the_bound_cannot_prove(tmp_path):
    """alpha_pc = 1, stress top: the tail bound (analytic.physics.tail) is far above the
    fastest roots (0.0066 and 0.0011 here; the bounds at k = 5 0.079 .. 0.014 from 4 to 32
    c_d), so the global maximum is the largest in R only, and the printed line and
    summary.json say so. (The velocity top proves there since session 32.)"""
    proc, s, _ = _envelope_at_1_and_3(tmp_path, ["--bc", "stress", "--alpha-pc", "1"])
    assert s["fastest_proven"] == {**s["fastest_proven"], "proven_k": 0, "k_with_root": 2}
    assert "in R only, R proven to hold the fastest mode at 0 of 2 k with a root" in proc.stdout


def test_envelope_proves_beyond_alpha_pc_delta_one(tmp_path):
    """alpha_pc |Delta - 1| = 1.2 (velocity top): no bound before session 32, now the
    multiplied-out one (tail.pc_velocity_bound) proves both samples, and each value is the
    fastest root of a region eight times as tall (32 c_d), searched on its own."""
    proc, s, out = _envelope_at_1_and_3(tmp_path, ["--alpha-pc", "0.6", "--Delta", "-1"])
    assert s["fastest_proven"] == {**s["fastest_proven"], "proven_k": 2, "k_with_root": 2}
    assert "R proven to hold the fastest mode at all 2 k with a root" in proc.stdout
    p = Params(alpha_pc=0.6, Delta=-1.0)
    with open(out / "envelope.csv") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        wide = fastest_mode(p, float(r["k"]), Region(1e-4, 2.0, 32.0)).root
        got = complex(float(r["re_lambda_max"]), float(r["im_lambda"]))
        # the same root found twice: measured below 1e-16 relative (polished roots)
        assert abs(got - wide) < 1e-12 * abs(wide)


@pytest.mark.parametrize("nproc", [1, 2])
@pytest.mark.parametrize("which", ["yes", "all"])
def test_envelope_fe_check_finds_every_local_maximum(tmp_path, which, nproc):
    """``envelope.py --fe-check yes``: each local maximum of the envelope (exact roots) is the
    FE's own fastest eigenvalue at its k (the sweep's FE path, no exact root consulted), set
    against an exact root polished from the FE value here; ``all``: every sample too."""
    out = tmp_path / "env"
    proc = run_workflow("envelope.py", ["--k", "1,3,6,10", "--refine-rounds", "0",
                                        "--fe-check", which, "--out", str(out)], nproc=nproc)
    assert proc.returncode == 0, proc.stderr[-2000:]
    s = json.loads((out / "summary.json").read_text())
    peaks, fe = s["global_max_on_grid"]["local_peaks"], s["fe_check"]
    with open(out / "envelope.csv") as fh:
        samples = {float(r["k"]): complex(float(r["re_lambda_max"]), float(r["im_lambda"]))
                   for r in csv.DictReader(fh)}
    assert len(peaks) == 2  # kH ~ 0.88 (the 0- branch) and the grid's k = 9.1
    want = {pk["k"]: complex(pk["re_lambda"], pk["im_lambda"]) for pk in peaks}
    if which == "all":
        want |= samples
    # each point once: the peaks in their order, or every point in k order
    assert [r["k"] for r in fe] == (sorted(want) if which == "all" else list(want))
    for r in fe:
        assert r["fe_closed"] and r["fe_proven"]
        z = complex(r["fe_re_lambda"], r["fe_im_lambda"])
        exact = polish_root(Params(), r["k"], z).value
        # FE (P6, the 1e-8 rule) against exact: measured 6.6e-14 and 2.2e-14 relative
        assert abs(z - exact) < 1e-9 * abs(exact)
        assert abs(z - want[r["k"]]) < 1e-9 * abs(exact)
    n = len(want)
    assert f"FE check: {n} of {n} point(s) found again by the FE on its own" in proc.stdout
    if which == "all":
        check_fe_maximum(s, Params())
        assert "FE's own maximum: Re Lambda = " in proc.stdout


def check_fe_maximum(s: dict, p: Params) -> None:
    """``envelope.py --fe-check all``'s ``fe_maximum``, the FE's own maximum over k: the exact
    envelope's refined maxima are its referee, and an exact root polished at the FE's k and
    either side of it says independently that the FE's k is a maximum of that mode."""
    fm, exact = s["fe_maximum"], s["global_max_on_grid"]
    assert fm["agrees"] and fm["local_maxima_as_exact"]
    assert len(fm["local_peaks"]) == len(exact["local_peaks"])
    for g in fm["local_peaks"]:  # each FE peak is the exact refined peak of its interval
        assert g["same_mode"] and g["fe_closed"] and g["fe_proven"] and g["lost"] == 0
        ex = min(exact["local_peaks"], key=lambda q: abs(q["k"] - g["k"]))
        # both Brent searches stop at 1e-8 of the interval's end in k; measured at most 1.4e-7
        # (k = 1, 3, 6, 10) and 7.4e-8 (the committed envelopes, k to 100) apart
        assert abs(g["k"] - ex["k"]) < 1e-6 * ex["k"]
        # Re at a maximum is flat in k: measured at most 3.3e-9 of Re (stress, 1.7e-12 of
        # |Lambda|; the FE error at the 1e-8 rule, as at every sample)
        assert abs(g["fe_re_lambda"] - ex["re_lambda"]) < 1e-8 * ex["re_lambda"]
    k, z = fm["k"], complex(fm["re_lambda"], fm["im_lambda"])
    at = polish_root(p, k, z).value
    assert abs(at - z) < 1e-9 * abs(z)  # the FE's error at the 1e-8 rule, as above
    for side in (k * (1 - 1e-4), k * (1 + 1e-4)):  # a smooth maximum: lower on both sides
        assert polish_root(p, side, at).value.real < at.real
    assert fm["re_lambda"] == max(g["fe_re_lambda"] for g in fm["local_peaks"])


@pytest.mark.parametrize("nproc", [1, 2])
def test_contrast_rigid_limit_and_rows(tmp_path, nproc):
    out = tmp_path / "c"
    proc = run_workflow("contrast.py", ["--mu2-grid", "3,1e6", "--H2s", "H", "--k", "1,2",
                                        "--out", str(out)], nproc=nproc)
    assert proc.returncode == 0, proc.stderr[-2000:]
    s = json.loads((out / "summary.json").read_text())
    rows = s["rows"]
    assert [r["mu2"] for r in rows] == [3.0, 1e6]
    # a stiff substrate approaches the rigid model: its largest growth over the same k samples
    rigid = Params()
    region = Region(1e-4, 2.0, 4.0)
    ks = np.unique(np.concatenate([[1.0, 2.0], np.linspace(1.0, 2.0, 8)]))
    exact = max(z.value.real for k in ks for z in roots_in_box(rigid, k, region.box(rigid, k)))
    # mu2 = 1e6: roots move by O(1/mu2) (docs/twobody.md: first order in 1/mu2)
    assert rows[1]["re_lambda"] == pytest.approx(exact, abs=1e-4)
    assert rows[0]["re_lambda"] < rows[1]["re_lambda"]
    # neither case can be proven in the 4 c_d region: mu2 = 3 (rho2 = 1), whose phase rates
    # are not commensurate, has bounds 0.087 and 0.162 there against its fastest roots 0.077
    # and 0.136 at k = 1, 2 (--c-max auto proves them at 16 and 8 c_d2: tests/test_tail.py),
    # mu2 = 1e6 a bound that is inf below 2 k c_d2 (c_d2 = 2000);
    # the line says the maximum is the largest in R only
    assert [(r["proven_k_count"], r["k_with_root"]) for r in rows] == [(0, 2), (0, 2)]
    assert "in R only, R proven to hold the fastest mode at 0 of 4 k with a root" in proc.stdout


@pytest.mark.parametrize("nproc", [1, 2])
def test_contrast_fe_check_finds_the_points_on_its_own(tmp_path, nproc):
    """``--fe-check yes``: at each finite-H2 point the FE's own fastest eigenvalue at the
    point's k (no exact root consulted) is the exact point; a half-space substrate has no FE
    model and says so. The FE's value is set against an exact root polished on its own here."""
    out = tmp_path / "c"
    proc = run_workflow("contrast.py", ["--mu2-grid", "3", "--H2s", "H,inf", "--k", "1,2",
                                        "--fe-check", "yes", "--out", str(out)], nproc=nproc)
    assert proc.returncode == 0, proc.stderr[-2000:]
    with open(out / "contrast.csv") as fh:
        rows = list(csv.DictReader(fh))
    finite, half = rows
    assert finite["fe_closed"] == "True" and int(finite["fe_count"]) > 0
    fe = complex(float(finite["fe_re_lambda"]), float(finite["fe_im_lambda"]))
    q = Params(mu2=3.0, H2=0.5)
    exact = polish_root(q, float(finite["k"]), fe).value
    # FE (P6, --rtol 1e-8 rule) against the exact root: measured 2.2e-14 relative
    assert abs(fe - exact) < 1e-9 * abs(exact)
    assert abs(fe - complex(float(finite["re_lambda"]), float(finite["im_lambda"]))) \
        < 1e-9 * abs(exact)
    assert float(finite["fe_rel_diff"]) < 1e-9
    assert half["fe_re_lambda"] == "" and "half-space" in half["fe_note"]
    assert "FE check: 1 of 1 point(s) found again by the FE on its own" in proc.stdout
    assert "0 FE count(s) not closed" in proc.stdout


@pytest.mark.parametrize(("rows", "line", "failed"), [
    ([{"re_lambda": 0.3}], None, 0),  # no check asked: no line
    ([{"fe_closed": None, "fe_note": "not run: ..."}],
     "FE check: none of 1 point(s) run (see fe_note)", 0),
    ([{"fe_closed": True, "fe_rel_diff": 1e-12}, {"fe_closed": False, "fe_rel_diff": 0.2},
      {"fe_closed": None, "fe_note": "no FE model of a half-space substrate"}],
     "FE check: 1 of 2 point(s) found again by the FE on its own (largest relative difference "
     "from the exact point 0.2); 1 FE count(s) not closed; 1 point(s) not run (see fe_note)", 1),
    # closed, but the FE's fastest is another mode (2e-6 > SAME_MODE): FE and exact disagree
    ([{"fe_closed": True, "fe_rel_diff": 2e-6}, {"fe_closed": True, "fe_rel_diff": 3e-11}],
     "FE check: 1 of 2 point(s) found again by the FE on its own (largest relative difference "
     "from the exact point 2e-06); 0 FE count(s) not closed; 1 closed count(s) whose fastest "
     "eigenvalue is not the point", 1),
    ([{"fe_closed": True, "fe_rel_diff": None, "fe_note": "no eigenvalue in the region"}],
     "FE check: 0 of 1 point(s) found again by the FE on its own (largest relative difference "
     "from the exact point nan); 0 FE count(s) not closed; 1 closed count(s) whose fastest "
     "eigenvalue is not the point", 1),
])
def test_fe_report_says_what_was_found_run_and_not_run(rows, line, failed):
    """``_points.fe_report``: a check asked for never ends silent (points it could not run are
    counted), a point is found only within SAME_MODE, an unclosed count and a closed one on
    another mode are failures (returned: the scene's exit 1)."""
    from _points import fe_report

    assert fe_report(rows) == (line, failed)


SAMPLE = {"k": 2.0, "fe_re_lambda": 0.3, "fe_im_lambda": -8.0, "fe_closed": True}
PEAK = {"k": 1.8, "fe_re_lambda": 0.32, "fe_im_lambda": -7.0, "same_mode": True}


@pytest.mark.parametrize(("samples", "peaks", "exact", "want"), [
    ([SAMPLE], [PEAK], {"k": 1.8, "re_lambda": 0.32, "im_lambda": -7.0},
     {"source": "refined peak", "agrees": True, "k_rel_diff": 0.0}),
    # a peak whose certified fastest is not the mode refined does not count
    ([SAMPLE], [PEAK | {"same_mode": False}], {"k": 1.8, "re_lambda": 0.32, "im_lambda": -7.0},
     {"source": "sample", "agrees": False}),
    # an unclosed sample does not count; nothing left but an exact maximum: disagreement
    ([SAMPLE | {"fe_closed": False}], [], {"k": 2.0, "re_lambda": 0.3, "im_lambda": -8.0},
     {"re_lambda": None, "agrees": False}),
    ([{"k": 2.0, "fe_re_lambda": None}], [], None, {"re_lambda": None, "agrees": True}),
    # another mode, 1e-5 away: not the same (SAME_MODE = 1e-6)
    ([SAMPLE], [], {"k": 2.0, "re_lambda": 0.3, "im_lambda": -8.0 * (1 + 1e-5)},
     {"source": "sample", "agrees": False}),
])
def test_fe_maximum_agrees_only_on_the_same_mode(samples, peaks, exact, want):
    """``_points.fe_maximum``: the FE's largest value counts closed samples and peaks certified
    as the mode refined, and agrees with the exact maximum only on the same mode."""
    from _points import fe_maximum

    got = fe_maximum(samples, peaks, exact)
    assert {key: got[key] for key in want} == want


@pytest.mark.parametrize("top", ["velocity", "stress"])
def test_committed_envelope_found_by_the_fe_at_every_point(top):
    """README "Envelope", session 40: the committed ``envelope.py --fe-check all`` runs. At every
    sample (255 stress, 300 velocity; k up to 100) and each of the 6 refined local maxima the
    envelope's value is the FE's own fastest eigenvalue at that k, in a region the FE's own
    climb proves, counts closed (stress: 261 points, at most 8.7e-13 relative from the exact
    point). Re-checked here against an exact root polished from each FE value. Session 41:
    the six largest local maxima of the FE's own samples refined along the FE's modes and
    certified at their k (``fe_maximum``) are the exact refined maxima."""
    folder = os.path.join(os.path.dirname(__file__), "..", "workflows", "results",
                          f"envelope_{top}")
    with open(os.path.join(folder, "summary.json")) as fh:
        s = json.load(fh)
    with open(os.path.join(folder, "envelope.csv")) as fh:
        want = {float(r["k"]): complex(float(r["re_lambda_max"]), float(r["im_lambda"]))
                for r in csv.DictReader(fh) if r["re_lambda_max"]}
    peaks, fe = s["global_max_on_grid"]["local_peaks"], s["fe_check"]
    assert len(peaks) == 6 and len(want) == s["samples"]
    want |= {pk["k"]: complex(pk["re_lambda"], pk["im_lambda"]) for pk in peaks}
    assert [r["k"] for r in fe] == sorted(want)
    p = Params(bc=top)
    for r in fe:
        assert r["fe_closed"] and r["fe_proven"]
        z = complex(r["fe_re_lambda"], r["fe_im_lambda"])
        # the FE at the sweep's 1e-8 rule: the file's largest, 8.7e-13 (stress)
        assert abs(z - want[r["k"]]) < 1e-9 * abs(z)
        exact = polish_root(p, r["k"], z).value
        assert abs(z - exact) < 1e-9 * abs(exact)
    check_fe_maximum(s, p)  # session 41: the maximum, refined by the FE on its own


def test_committed_contrast_points_found_by_the_fe():
    """README "Contrast curve", session 38: the committed ``contrast.py --c-max auto --fe-check
    yes`` run. At every finite-H2 point with a root the FE, on its own at the point's k, found
    the exact point (closed count; measured 1.5e-10 relative at most, P6 and the 1e-8 rule);
    the half-space points say they have no FE model. Re-checked here against an exact root
    polished from the FE value (independent of the curve's count)."""
    path = os.path.join(os.path.dirname(__file__), "..", "workflows", "results",
                        "contrast_auto", "contrast.csv")
    with open(path) as fh:
        rows = list(csv.DictReader(fh))
    finite = [r for r in rows if r["H2"] != "inf" and r["re_lambda"]]
    assert len(finite) == 12
    for r in finite:
        assert r["fe_closed"] == "True" and float(r["fe_rel_diff"]) < 1e-9
        fe = complex(float(r["fe_re_lambda"]), float(r["fe_im_lambda"]))
        q = Params(mu2=float(r["mu2"]), rho2=float(r["rho2"]), H2=float(r["H2"]))
        exact = polish_root(q, float(r["k"]), fe).value
        assert abs(fe - exact) < 1e-9 * abs(exact)
    assert all("half-space" in r["fe_note"] for r in rows if r["H2"] == "inf")


@pytest.mark.parametrize("script, bad, word", [("contrast.py", ["--H2s", "0"], "--H2s"),
                                               ("contrast.py", ["--mu2", "-1"], "mu2"),
                                               ("envelope.py", ["--k", "2:1:10log"], "--k"),
                                               ("envelope.py", ["--min-ratio", "1"],
                                                "--min-ratio"),
                                               ("envelope.py", ["--refine-rounds", "-1"],
                                                "--refine-rounds"),
                                               ("envelope.py", ["--mu2", "3", "--H2", "0.5"],
                                                "mu2")])
def test_bad_input_one_line(tmp_path, script, bad, word):
    proc = run_workflow(script, [*bad, "--out", str(tmp_path / "o")])
    assert proc.returncode == 2
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and word in lines[0], proc.stderr
    assert not (tmp_path / "o").exists()


def test_envelope_without_any_root_in_the_region(tmp_path):
    """Frictionless sliding (f = 0): every root is neutral, none has Re >= 1e-3 (no maximum)."""
    out = tmp_path / "e"
    proc = run_workflow("envelope.py", ["--f", "0", "--re-min", "1e-3", "--k", "1,2", "--out",
                                        str(out)])
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "no root in the region" in proc.stdout
    s = json.loads((out / "summary.json").read_text())
    assert s["global_max_on_grid"] is None and s["large_kH"]["re_lambda_max"] is None
    with open(out / "envelope.csv") as fh:
        assert all(r["re_lambda_max"] == "" for r in csv.DictReader(fh))


#: A sitecustomize.py for the child: every argument-principle count raises ContourError.
COUNT_FAILS = """
import analytic.numerics.roots as _roots


def _failing(*args, **kwargs):
    raise _roots.ContourError("injected by the test: the count fails")


_roots.winding_numbers = _failing
"""


def test_contrast_reports_a_failed_count_in_its_exit_code(tmp_path):
    """A count that fails (injected: every count raises ContourError) is reported per grid k
    and in the exit code. The genuine case used before (gamma = 0.001, mu2 = 1e4, H2 = H = 1,
    k = 0.05, Re >= 1e-6) was the zero test of the contour, not a root on it: the nearest
    root, -1.66e-6 + 9.827i, is outside the region, and since session 12 (the zero test
    against the median sample) that count closes; no cheap genuine failure of the two-body
    count is known."""
    inject = tmp_path / "inject"
    inject.mkdir()
    (inject / "sitecustomize.py").write_text(COUNT_FAILS)
    out = tmp_path / "c"
    proc = run_workflow("contrast.py", ["--mu2-grid", "10000", "--H2s", "H", "--H", "1",
                                        "--gamma", "0.001", "--Delta", "0.75", "--k", "0.05",
                                        "--re-min", "1e-6", "--c-max", "4",
                                        "--out", str(out)], prepend=[inject])
    with open(out / "contrast.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["failed_counts"]) for r in rows] == [1]
    assert proc.returncode == 1, proc.stderr[-2000:]
    assert "warning: the count failed at 1 grid k value(s)" in proc.stderr


# ------------------------------------------------------------- analytic.studies.growth (direct)
@pytest.mark.parametrize("growth, monotonic, changes", [([0.1, 0.2, 0.2, 0.5], True, 0),
                                                        ([0.5, 0.5, 0.3, 0.0], True, 0),
                                                        ([0.1, 0.4, 0.2, 0.3], False, 2)])
def test_curve_shape(growth, monotonic, changes):
    x = [0.1, 1.0, 10.0, 100.0]
    c = curve_shape(x, growth, "mu2")
    assert c == {"max_growth": max(growth), "mu2_at_max": x[growth.index(max(growth))],
                 "monotonic": monotonic, "direction_changes": changes}


def test_best_over_k_is_a_fastest_root_at_least_the_grid_maximum():
    p, region, ks = Params(), Region(1e-4, 2.0, 4.0), np.array([1.0, 2.0, 4.0])
    best = best_over_k(p, ks, region)
    grid = [fastest_root(p, k, region)[0] for k in ks]
    assert best["failed_counts"] == 0
    assert best["re_lambda"] >= max(z.real for z in grid)
    z = fastest_root(p, best["k"], region)[0]  # the value is the fastest root at its k
    assert complex(best["re_lambda"], best["im_lambda"]) == z


def test_envelope_maximum_refines_the_grid_maximum():
    p, region, ks = Params(), Region(), [1.0, 3.0, 6.0, 9.0]
    zs = [fastest_root(p, k, region)[0] for k in ks]
    best = envelope_maximum(p, region, ks, zs)
    j = int(np.argmax([z.real for z in zs]))
    assert best["grid_k_of_largest_value"] == ks[j] and best["at_grid_edge"] == (j in (0, 3))
    assert best["re_lambda"] >= zs[j].real and best["kH"] == best["k"] * p.H
    z = fastest_root(p, best["k"], region)[0]
    # a refined peak is a root of the exact family polished to 1e-8 relative (the check in
    # refine_envelope): the fastest root at its k within that
    assert abs(complex(best["re_lambda"], best["im_lambda"]) - z) <= 1e-8 * abs(z)
    # the maximum is the largest of the refined peaks that are the fastest in the region
    assert all(pk["re_lambda"] <= best["re_lambda"] for pk in best["local_peaks"]
               if pk["fastest_in_region"])


@pytest.mark.slow  # 22-35 s: 14 root counts up to k = 6
def test_envelope_refines_every_extremum(tmp_path):
    """The grid 2, 3.46, 6 (velocity top, H = 0.5) is monotone; the envelope has a dip near
    k = 2.76 (a change of family) and a peak near k = 3.97 (measured with --k 0.5:6:4log
    --min-ratio 1.05: 0.2546 and 0.2871). The refinement must find both, every extremum resolved
    to the ratio, and every value an exact fastest root."""
    out = tmp_path / "env"
    proc = run_workflow("envelope.py", ["--k", "2:6:3log", "--min-ratio", "1.1", "--out",
                                        str(out)])
    assert proc.returncode == 0, proc.stderr[-2000:]
    with open(out / "envelope.csv") as fh:
        rows = list(csv.DictReader(fh))
    ks = [float(r["k"]) for r in rows]
    re = [float(r["re_lambda_max"]) for r in rows]
    ext = local_extrema(re)
    grid = np.geomspace(2.0, 6.0, 3)

    def bracket(j):  # the envelope at the two grid samples around ks[j]
        i = int(np.searchsorted(grid, ks[j]))
        return [re[ks.index(float(g))] for g in grid[max(i - 1, 0):i + 1]]

    assert any(re[j] < min(bracket(j)) for j in ext)  # a dip the grid does not show
    assert any(re[j] > max(bracket(j)) for j in ext)  # a peak the grid does not show
    assert extremum_midpoints(ks, re, 1.1) == []
    s = json.loads((out / "summary.json").read_text())
    assert s["local_minima"] and s["samples"] == len(rows) > s["grid_samples"] == 3
    p, region = Params(), Region()
    for j in ext[:2]:
        assert re[j] == pytest.approx(fastest_root(p, ks[j], region)[0].real, rel=1e-10)


@pytest.mark.parametrize("k_dip", [1.7, 3.3, 7.9])
def test_extremum_midpoints_resolve_a_dip_between_samples(k_dip):
    """An envelope of two crossing families, max(a, b), has a kink dip at k_dip that the grid
    k_dip * exp(-1.6, 0.7, 2.5) jumps over (it shows only the peak of b): repeated midpoints
    around every extremum find the dip, to the ratio."""

    def env(k):
        x = np.log(k / k_dip)
        return np.maximum(1.0 - 0.05 * x, 1.0 + 0.5 * x - 0.3 * x**2)

    ks = list(k_dip * np.exp([-1.6, 0.7, 2.5]))
    assert local_extrema(env(np.array(ks))) == [1]  # the grid shows the peak only
    for _ in range(60):
        new = extremum_midpoints(ks, list(env(np.array(ks))), 1.01)
        if not new:
            break
        ks = sorted(set(ks) | set(new))
    vals = env(np.array(ks))
    dips = [j for j in local_extrema(vals) if vals[j] <= min(vals[j - 1], vals[j + 1])]
    assert new == [] and len(dips) == 1
    assert abs(np.log(ks[dips[0]] / k_dip)) <= np.log(1.01)


def test_local_extrema_interior_only():
    assert local_extrema([0.0, 1.0, 0.5, 0.7, np.nan, 0.2, 0.1]) == [1, 2]


def _follow(p, k, z, name, value, steps=20):
    """The root z of p at k, continued in one parameter to value (Newton, equal steps)."""
    v0 = getattr(p, name)
    for s in np.linspace(0.0, 1.0, steps + 1)[1:]:
        r = polish_root(p.replace(**{name: v0 + s * (value - v0)}), k, z)
        assert r.converged
        z = r.value
    return z


@pytest.mark.parametrize("bc, guess", [("velocity", 0.32989 - 169.740j),
                                       ("stress", 0.35103 - 308.390j)])
def test_plateau_scales_as_one_over_H(bc, guess):
    """docs/envelope.md section 2: at |Lambda| >> 1 the roots are F(kH) / H, independent of
    Delta; the growth needs f > 0, rises with gamma and vanishes with alpha_pc. The root is the
    envelope's local maximum at kH = 22.27, H = 0.5 (workflows/results/envelope_*; the guess is
    only Newton's start). Tolerances: measured changes of H Lambda were <= 2.4e-5 (H = 0.5 -> 2)
    and of Re Lambda <= 1.8e-4 (Delta = 0.7 -> 5 or -0.5), the O(1/|Lambda|) corrections;
    with alpha_pc = 1, Re Lambda was 1.1e-5 (velocity) and 3.3e-6 (stress)."""
    p, k = Params(bc=bc, H=0.5), 44.54783436305254
    z = polish_root(p, k, guess).value
    for h in (1.0, 2.0):
        r = polish_root(p.replace(H=h), k * p.H / h, z * p.H / h)
        assert r.converged and abs(r.value.real * h - z.real * p.H) <= 1e-4
    for delta in (5.0, -0.5):
        assert abs(_follow(p, k, z, "Delta", delta).real - z.real) <= 1e-3
    assert _follow(p, k, z, "gamma", 1.0).real < z.real < _follow(p, k, z, "gamma", 10.0).real
    assert abs(_follow(p, k, z, "alpha_pc", 1.0).real) <= 1e-4 * z.real
    assert _follow(p, k, z, "f", 0.0).real < 0


def test_plateau_dependence_panels():
    """The three panels of envelope.py --dependence for the velocity top's plateau mode at
    kH = 22.27: H Re Lambda constant in H (to 1e-4, as test_plateau_scales_as_one_over_H),
    falling to below 1e-4 of its value at alpha_pc = 1, rising with f gamma above f gamma = 0.3
    (measured: -0.004 at gamma = 1, 0.23 at gamma = 10)."""
    p, k = Params(), 44.54783436305254
    z = polish_root(p, k, 0.32989 - 169.740j).value
    dep = plateau_dependence(p, k, z)
    h = [w for _, w in dep["H"]]
    assert None not in h and max(h) - min(h) <= 1e-4
    apc = dict((round(v, 6), w) for v, w in dep["alpha_pc"])
    assert apc[0.0] == pytest.approx(z.real * p.H, rel=1e-12) and abs(apc[1.0]) <= 1e-4 * apc[0]
    fg = [(v, w) for v, w in dep["f_gamma"] if v >= 0.3]
    assert all(b[1] > a[1] for a, b in zip(fg, fg[1:], strict=False))


@pytest.mark.parametrize("top", ["stress", "velocity"])
def test_committed_envelopes_are_proven_at_every_sample(top):
    """README (session 24): the committed envelopes (workflows/results/envelope_*) say the
    fastest mode is proven at every sample; recomputed independently at the smallest k (where
    the stress top's box goes beyond the ladder's top, 32 c_d): fastest_mode proves it and gives
    the same Re Lambda (both Newton-polished roots of det_M: measured equal to 1e-15)."""
    folder = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                          "workflows", "results", f"envelope_{top}")
    with open(os.path.join(folder, "envelope.csv")) as fh:
        rows = list(csv.DictReader(fh))
    with open(os.path.join(folder, "summary.json")) as fh:
        s = json.load(fh)
    assert [r["fastest_proven"] for r in rows] == ["1"] * len(rows)
    assert s["fastest_proven"]["proven_k"] == s["fastest_proven"]["k_with_root"] == len(rows)
    r = min(rows, key=lambda r: float(r["k"]))
    m = fastest_mode(Params(bc=top), float(r["k"]), Region(c_max=None))
    assert m.proven and m.root.real == pytest.approx(float(r["re_lambda_max"]), rel=1e-10)
    if top == "stress":
        assert m.c_max > 32.0  # beyond the ladder's top
