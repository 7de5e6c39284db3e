"""``sweep_k.py --model layers`` with several layers or profiles: FE first, no exact roots.

A layered or graded slider has no closed form in ``analytic``'s sweep, so the scene runs the
FE-first path with ``--check-exact no`` (tests in tests/test_fe_first.py prove that path for the
homogeneous slider). Here, against the exact layered determinant of
``analytic/physics/layered_exact.py`` (transfer matrices, written independently of the FE):

- every FE eigenvalue the scene reports at two ``k`` is a distinct converged root of
  ``det_layered`` (Newton from the FE value), and the argument-principle count of
  ``det_layered`` in the box the scene used equals the FE count (serial and ``mpirun -n 2``;
  the scene runs with ``analytic``'s homogeneous root paths made unavailable);
- the labels follow the eigenpairs in ``k`` (:func:`forms.studies.sweep.label_by_continuation`);
- a smooth profile converges at ``h^(2p)`` through the scene.
"""

import csv
import json
import math
import os

import numpy as np
import pytest
from test_fe_first import NO_EXACT, _scene

from analytic.numerics.roots import count_zeros
from analytic.params import Params
from analytic.physics.layered_exact import ExactLayer, det_layered, follow_layered, layered_root
from forms.solvers.certified import KResult
from forms.studies.sweep import label_by_continuation

#: A compliant, denser, slower layer under the body (tests/test_profiles.py uses it too).
TWO_LAYERS = "y_top,mu,rho,beta\n0.1,0.6,1.3,0.45\n0.5,1,1,0.5\n"
EXACT_TWO = [ExactLayer(0.0, 0.1, 0.6, 1.3, 0.45), ExactLayer(0.1, 0.5, 1.0, 1.0, 0.5)]


def _read(out):
    with open(os.path.join(out, "spectrum.csv")) as fh:
        rows = list(csv.DictReader(fh))
    with open(os.path.join(out, "summary.json")) as fh:
        return rows, json.load(fh)


def _value(row) -> complex:
    return complex(float(row["re_lambda"]), float(row["im_lambda"]))


@pytest.mark.slow  # measured 20 to 35 s each (scene start-up, exact count) on the loaded machine
@pytest.mark.serial
@pytest.mark.parametrize("bc,nproc", [("velocity", 1), ("stress", 1), ("velocity", 2)])
def test_two_layers_every_fe_value_is_an_exact_root_and_counts_agree(tmp_path, bc, nproc):
    """Two k: FE values = distinct exact layered roots; exact count in the box = FE count."""
    layers = tmp_path / "two.csv"
    layers.write_text(TWO_LAYERS)
    out = str(tmp_path / "out")
    proc = _scene(["--model", "layers", "--layers", str(layers), "--bc", bc, "--k", "1,2.5",
                   "--layers-bound", "no"], out, nproc=nproc, preamble=NO_EXACT, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows, summary = _read(out)
    assert summary["check_exact"] is False and summary["families"]["count"] == 0
    # --layers-bound no: not proven, and the summary says why
    assert summary["region"]["proven_to_hold_fastest_mode"] is False
    assert "--layers-bound no" in summary["region"]["why_not"]
    assert summary["most_unstable"]["certificate"]["fastest_mode"] is False
    # the largest c_d of the stack: the second layer's 1/beta = 2 (the first: sqrt(0.6/1.3)/0.45)
    assert summary["region"]["velocity_scale"] == pytest.approx(2.0, rel=1e-12)
    assert {r["certificate"] for r in rows} == {"fe"} and {r["status"] for r in rows} == {"ok"}
    p = Params(bc=bc)
    for per_k in summary["per_k"]:
        k, box = per_k["k"], per_k["box"]
        # the box: |Im| <= 4 k c_d,max + 2 pi c_d,max / H, c_d,max = 2, H = 0.5
        assert box[3] == pytest.approx(8.0 * k + 8.0 * math.pi, rel=1e-12)
        fe = [_value(r) for r in rows if float(r["k"]) == k]
        exact = []
        for lam in fe:
            root = layered_root(lam, k, p, EXACT_TWO)
            assert root.converged
            # the sweep's --rtol (1e-8, default); measured 2026-11-24 (P4, default mesh): at
            # most 1.1e-10 (velocity), 3.2e-10 (stress)
            assert abs(root.value - lam) < 1e-8 * abs(root.value)
            exact.append(root.value)
        gaps = [abs(a - b) for i, a in enumerate(exact) for b in exact[:i]]
        assert not gaps or min(gaps) > 1e-3  # distinct roots
        n = count_zeros(np.vectorize(lambda z, k=k: det_layered(complex(z), k, p, EXACT_TWO),
                                     otypes=[complex]), box)
        assert n == per_k["n_fe"] == len(fe) >= 2


#: A slow, dense layer under the body, its phase rates commensurate with the body's (c_s = 1/2).
SLOW_LAYER = "y_top,mu,rho,beta\n0.1,0.5,2,0.5\n0.5,1,1,0.5\n"
EXACT_SLOW = [ExactLayer(0.0, 0.1, 0.5, 2.0, 0.5), ExactLayer(0.1, 0.5, 1.0, 1.0, 0.5)]


@pytest.mark.slow  # measured about 15 s (the scene, two exact counts of a tall box)
@pytest.mark.serial
def test_layered_tail_bound_proves_and_a_taller_box_agrees(tmp_path):
    """Commensurate constant layers on a rigid substrate, velocity top, k = 1: the layers' tail
    bound (analytic.physics.tail_layers) at the first rung is below the fastest FE value, so
    the scene says R holds the fastest mode; the exact layered determinant in a box three times
    as tall counts no root above that value and one at and above 0.9999 of it."""
    layers = tmp_path / "slow.csv"
    layers.write_text(SLOW_LAYER)
    out = str(tmp_path / "out")
    proc = _scene(["--model", "layers", "--layers", str(layers), "--k", "1", "--layers-bound",
                   "yes"], out, preamble=NO_EXACT, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows, summary = _read(out)
    assert summary["region"]["proven_to_hold_fastest_mode"] is True
    assert summary["region"]["why_not"] == "" and summary["most_unstable"]["certificate"][
        "fastest_mode"] is True
    per_k = summary["per_k"][0]
    fastest = max(float(r["re_lambda"]) for r in rows)
    # measured: the bound 0.036 against the fastest 0.2455
    assert per_k["fastest_proven"] and 0 < per_k["tail_bound"] < fastest
    p, w = Params(), 3.0 * per_k["box"][3]

    def det(z: complex) -> complex:
        return det_layered(complex(z), 1.0, p, EXACT_SLOW)

    fun = np.vectorize(det, otypes=[complex])
    assert count_zeros(fun, (fastest * 1.0001, 2.0, -w, w)) == 0
    assert count_zeros(fun, (fastest * 0.9999, 2.0, -w, w)) >= 1
    # three layers whose rates are not commensurate (c_s sqrt(0.6/1.3) in the first): no bound
    # (two such layers have one since session 33: test_damage_zone_climbs_... below)
    odd = tmp_path / "three.csv"
    odd.write_text(TWO_LAYERS.replace("0.5,1,1,0.5", "0.3,1,1,0.5\n0.5,0.8,1,0.5"))
    proc = _scene(["--model", "layers", "--layers", str(odd), "--k", "1", "--layers-bound",
                   "yes", "--no-plot"], str(tmp_path / "odd"), preamble=NO_EXACT, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    _, summary = _read(str(tmp_path / "odd"))
    assert summary["region"]["proven_to_hold_fastest_mode"] is False
    assert "not commensurate" in summary["region"]["why_not"]
    assert summary["per_k"][0]["tail_bound"] is None


#: The README's damage zone: c_s = sqrt 0.6 under c_s = 1, rates not commensurate.
DAMAGE_ZONE = "y_top,mu,rho,beta\n0.05,0.6,1,0.5\n0.5,1,1,0.5\n"
EXACT_DAMAGE = [ExactLayer(0.0, 0.05, 0.6, 1.0, 0.5), ExactLayer(0.05, 0.5, 1.0, 1.0, 0.5)]


@pytest.mark.slow  # measured about 20 s at k = 1.7, 12 s at k = 20 (the scene, two counts)
@pytest.mark.serial
@pytest.mark.parametrize("k", [1.7, 20.0])
def test_damage_zone_climbs_until_its_tail_bound_proves_and_a_taller_box_agrees(tmp_path, k):
    """Layers whose rates are not commensurate (the free torus, session 33), stress top, k =
    1.7 and 20 (kH = 10): the first rung's tail bound is not below the fastest FE value there,
    so the region climbs (measured: to 6 and 12 c_d) until it is; the scene says R holds the
    fastest mode, and the exact layered determinant in a box three times as tall as the rung
    accepted counts no root above the fastest FE value and one at and above 0.9999 of it."""
    layers = tmp_path / "dz.csv"
    layers.write_text(DAMAGE_ZONE)
    out = str(tmp_path / "out")
    # the default --layers-bound (auto: yes with --model layers) asks for the bound
    proc = _scene(["--model", "layers", "--layers", str(layers), "--k", str(k), "--bc",
                   "stress", "--no-plot"], out, preamble=NO_EXACT, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows, summary = _read(out)
    region, per_k = summary["region"], summary["per_k"][0]
    assert region["proven_to_hold_fastest_mode"] is True and region["c_max"] == "auto"
    assert per_k["c_max"] > 4.0 and per_k["fastest_proven"]
    fastest = max(float(r["re_lambda"]) for r in rows)
    # measured: k = 1.7, 6 c_d, the bound 0.168 (0.8 of the target) against the fastest
    # 0.2096; k = 20, 12 c_d, 0.3040 against 0.30711 (at -181.6i)
    assert 0 < per_k["tail_bound"] < fastest
    p, w = Params(bc="stress"), 3.0 * per_k["box"][3]

    def det(z: complex) -> complex:
        return det_layered(complex(z), k, p, EXACT_DAMAGE)

    fun = np.vectorize(det, otypes=[complex])
    # about 2.6 samples per unit of the long side (at k = 20, |Im| <= 1515: 4 000; from 32
    # the refinement hit its 50 000-sample guard there, session 33)
    n0 = max(32, int(2.6 * w))
    assert count_zeros(fun, (fastest * 1.0001, 2.0, -w, w), n_initial=n0) == 0
    assert count_zeros(fun, (fastest * 0.9999, 2.0, -w, w), n_initial=n0) >= 1


def _res(k: float, values: list[complex], nexts: list[complex]) -> KResult:
    rows = [{"k": k, "label": "", "re_lambda": z.real, "im_lambda": z.imag,
             "re_next": n.real, "im_next": n.imag} for z, n in zip(values, nexts, strict=True)]
    return KResult(k, rows)


@pytest.mark.serial
def test_label_by_continuation_links_mutual_nearest_only():
    """Linked when the continued value lands on a row (1e-6); crossings keep their labels."""
    nan = complex(math.nan, math.nan)
    # k0: a (|Im| 1) and b (|Im| 2); continued to k1 they cross in |Im|
    r0 = _res(0.0, [0.1 - 1j, 0.2 - 2j], [0.2 - 2.5j, 0.1 - 1.5j])
    # k1: both continued values present, plus a new mode; b's continuation is lost at k1
    r1 = _res(1.0, [0.1 - 1.5j, 0.2 - 2.5j, 0.3 - 3j], [nan, 0.2 - 2.6j, 0.3 - 3.1j])
    # k2: a's continued value missed by 1e-5 (not linked); the others linked
    r2 = _res(2.0, [0.2 - 2.6j * (1 + 1e-5), 0.3 - 3.1j], [nan, nan])
    assert label_by_continuation([r0, r1, r2]) == 4
    lab = [{complex(r["re_lambda"], r["im_lambda"]): r["label"] for r in res.rows}
           for res in (r0, r1, r2)]
    assert lab[0] == {0.1 - 1j: "c0", 0.2 - 2j: "c1"}
    assert lab[1] == {0.1 - 1.5j: "c1", 0.2 - 2.5j: "c0", 0.3 - 3j: "c2"}
    assert lab[2][0.3 - 3.1j] == "c2" and lab[2][0.2 - 2.6j * (1 + 1e-5)] == "c3"


@pytest.mark.slow  # measured about 20 s (three scene runs) on the loaded 2-core machine
@pytest.mark.serial
def test_smooth_profile_converges_at_order_2p_through_the_scene(tmp_path):
    """--mu-profile/--rho-profile at P2 on 8, 16, 32 cells: errors ~ h^4 against the exact."""
    p = Params()
    exact_layers = [ExactLayer(0.0, p.H, lambda y: 1 - 0.4 * np.exp(-y / 0.2),
                               lambda y: 1 + 0.5 * y, p.beta)]
    errors, exact = [], None
    for cells in (8, 16, 32):
        out = str(tmp_path / f"c{cells}")
        proc = _scene(["--model", "layers", "--mu-profile", "1 - 0.4*exp(-y/0.2)",
                       "--rho-profile", "1 + 0.5*y", "--k", "1", "--degree", "2",
                       "--cells", str(cells), "--rtol", "1e-2"], out, preamble=NO_EXACT)
        assert proc.returncode in (0, 1), proc.stderr[-2000:]
        rows, _ = _read(out)
        lam = max((_value(r) for r in rows), key=lambda z: z.real)
        if exact is None:
            exact = layered_root(lam, 1.0, p, exact_layers).value
        errors.append(abs(lam - exact) / abs(exact))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    # measured 2026-11-24 through the scene: orders 3.92, 3.98 (errors 1.8e-6, 1.2e-7, 7.3e-9),
    # as the package test (tests/test_profiles.py) on the same meshes
    assert np.all(orders > 4 - 0.6) and np.all(orders < 4 + 0.5), orders


RESULTS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "workflows",
                       "results")
#: README "A damage zone": per committed sweep (default k grid, paper defaults, velocity top),
#: the fastest row's peak over the grid (label, k, Re Lambda to the README's 6 digits) and the
#: labels that lead along k with their first and last grid k.
README_DAMAGE = {
    "homogeneous": ("sweep_k", "0-", 1.75, 0.327450,
                    [("0-", 0.05, 2.7), ("1-", 2.75, 5.0), ("2-", 5.05, 6.0)]),
    "layer": ("damage_zone/layer", "c0", 1.7, 0.309091,
              [("c0", 0.05, 2.6), ("c2", 2.65, 4.8), ("c3", 4.85, 6.0)]),
    "smooth": ("damage_zone/smooth", "c0", 1.7, 0.314109,
               [("c0", 0.05, 2.65), ("c2", 2.7, 5.05), ("c3", 5.1, 6.0)]),
}
#: The README's layer: mu = 0.6 for y < 0.05 (workflows/results/damage_zone/damage_zone_layers.csv).
EXACT_DZ = [ExactLayer(0.0, 0.05, 0.6, 1.0, 0.5), ExactLayer(0.05, 0.5, 1.0, 1.0, 0.5)]


def _committed(folder):
    with open(os.path.join(RESULTS, folder, "spectrum.csv")) as fh:
        return list(csv.DictReader(fh))


@pytest.mark.serial
@pytest.mark.parametrize("case", list(README_DAMAGE))
def test_damage_zone_readme_numbers_from_the_committed_sweeps(case):
    """The README's peaks and leaders, recomputed from the committed spectrum.csv files."""
    from forms.studies.sweep import envelope, envelope_changes

    folder, label, k_peak, re_peak, leaders = README_DAMAGE[case]
    got = envelope_changes(envelope(_committed(folder)))
    assert got["peak"]["label"] == label and got["peak"]["k"] == pytest.approx(k_peak, abs=1e-9)
    assert round(got["peak"]["re_lambda"], 6) == re_peak
    assert [(x["label"], round(x["k_from"], 6), round(x["k_to"], 6))
            for x in got["leaders"]] == leaders
    with open(os.path.join(RESULTS, "damage_zone", "fastest", "fastest.csv")) as fh:
        picture = [r for r in csv.DictReader(fh) if r["run"].startswith(
            {"homogeneous": "homogeneous", "layer": "mu = 0.6", "smooth": "mu = 1 -"}[case])]
    assert len(picture) == 120 and max(float(r["re_lambda"]) for r in picture) == pytest.approx(
        got["peak"]["re_lambda"], rel=1e-15)


@pytest.mark.slow  # measured about 20 s (the scene twice, climbs to 12-32 c_d)
@pytest.mark.serial
def test_layered_climb_is_the_same_on_one_and_two_ranks(tmp_path):
    """The layered climb (--layers-bound yes) decides each k's rung from that k alone: the
    damage zone's stress top at three k where it climbs to 12-32 c_d (measured) gives the same
    rungs, counts, proofs and values (to 1e-9) on one rank and on two."""
    layers = tmp_path / "dz.csv"
    layers.write_text(DAMAGE_ZONE)
    got = {}
    for nproc in (1, 2):
        out = str(tmp_path / f"np{nproc}")
        proc = _scene(["--model", "layers", "--layers", str(layers), "--k", "2.3,2.5,2.7",
                       "--bc", "stress", "--layers-bound", "yes"], out, nproc=nproc,
                      preamble=NO_EXACT, timeout=600)
        assert proc.returncode == 0, proc.stderr[-2000:]
        rows, summary = _read(out)
        got[nproc] = ([(d["k"], d["c_max"], d["n_fe"], d["fastest_proven"])
                       for d in summary["per_k"]], sorted((_value(r) for r in rows),
                                                          key=lambda z: (z.imag, z.real)))
    # measured: 12, 32 and 24 c_d, every k proven but 2.5 (the top rung's bound above its
    # fastest value there)
    assert got[1][0] == got[2][0] and max(c for _, c, _, _ in got[1][0]) == 32.0
    assert np.allclose(got[1][1], got[2][1], rtol=1e-9, atol=0)


@pytest.mark.slow  # measured about 6 s (an exact count of a tall box)
@pytest.mark.serial
def test_damage_zone_committed_run_is_proven_and_a_taller_box_agrees():
    """The README's layer run (--layers-bound yes, session 33) says R holds the fastest mode:
    its largest tail bound is below the peak (measured 0.247 against 0.3091), and at the peak
    k the exact layered determinant in a box three times as tall as the one used counts no
    root above the peak value and one at and above 0.9999 of it."""
    with open(os.path.join(RESULTS, "damage_zone", "layer", "summary.json")) as fh:
        summary = json.load(fh)
    best = summary["most_unstable"]
    assert summary["region"]["proven_to_hold_fastest_mode"] is True
    assert best["certificate"]["largest_tail_bound"] < best["re_lambda"]
    per_k = next(d for d in summary["per_k"] if d["k"] == best["k"])
    p, w, k = Params(), 3.0 * per_k["box"][3], best["k"]
    fun = np.vectorize(lambda z: det_layered(complex(z), k, p, EXACT_DAMAGE), otypes=[complex])
    assert count_zeros(fun, (best["re_lambda"] * 1.0001, 2.0, -w, w)) == 0
    assert count_zeros(fun, (best["re_lambda"] * 0.9999, 2.0, -w, w)) >= 1


@pytest.mark.serial
def test_damage_zone_layer_against_the_exact_layered_roots():
    """The layer's peak lies on the exact branch 0- (through 0.27 - 6.6i at k = 1), and the
    exact roots of the two leaders swap order between k = 2.6 and 2.65, as the FE rows say."""
    p = Params()
    rows = _committed("damage_zone/layer")

    def row(label, k):
        return next(_value(r) for r in rows
                    if r["label"] == label and abs(float(r["k"]) - k) < 1e-9)

    peak = row("c0", 1.7)
    branch = follow_layered(0.27 - 6.6j, 1.0, np.arange(1.0, 1.71, 0.05), p, EXACT_DZ)[-1]
    # the sweep's --rtol, 1e-8; measured 2026-11-24: 8.9e-13
    assert abs(branch - peak) < 1e-8 * abs(branch)
    for k, first in ((2.6, "c0"), (2.65, "c2")):
        exact = {lab: layered_root(row(lab, k), k, p, EXACT_DZ) for lab in ("c0", "c2")}
        assert all(r.converged for r in exact.values())
        assert max(exact, key=lambda lab: exact[lab].value.real) == first


@pytest.mark.serial
def test_damage_zone_readme_counts_and_branch_frequencies():
    """README: 571 / 570 / 559 rows, all ok, every k closed; c2, c3 within 5 % of 1-, 2- in
    frequency at k = 3 and 5.5."""
    for folder, n in (("damage_zone/layer", 571), ("damage_zone/smooth", 570), ("sweep_k", 559)):
        with open(os.path.join(RESULTS, folder, "summary.json")) as fh:
            cert = json.load(fh)["certificate"]
        assert cert["rows"] == cert["rows_ok"] == n and cert["k_closed"] == cert["k_values"]
    hom, lay = _committed("sweep_k"), _committed("damage_zone/layer")

    def im(rows, label, k):
        return next(abs(_value(r).imag) for r in rows
                    if r["label"] == label and abs(float(r["k"]) - k) < 1e-9)

    for k in (3.0, 5.5):
        for ours, theirs in (("c2", "1-"), ("c3", "2-")):
            # measured: 4.9 % (c2, k = 3), 4.1 %, 4.3 %, 3.9 %
            assert abs(im(lay, ours, k) / im(hom, theirs, k) - 1) < 0.05
