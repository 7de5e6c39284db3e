import numpy as np
import pytest

from analytic.numerics import roots
from analytic.numerics.roots import ContourError, count_zeros, polish, winding_number, zeros_in_box
from analytic.numerics.spectrum import Region
from analytic.params import Params
from analytic.physics.finite_h import det_M

# Pure numpy (no MPI, no FE): the serial pass is enough.
pytestmark = pytest.mark.serial

ROOTS = np.array([0.3 + 0.2j, -0.7 + 0.1j, 0.25 - 0.6j, 1.5 + 1.5j, 0.31 + 0.21j])


def poly(z):
    z = np.asarray(z, dtype=complex)
    out = np.ones_like(z)
    for r in ROOTS:
        out = out * (z - r)
    return out


@pytest.mark.parametrize(
    "box,expected",
    [
        ((-1, 1, -1, 1), 4),  # all but 1.5+1.5j
        ((-2, 2, -2, 2), 5),
        ((0.0, 0.5, 0.0, 0.5), 2),  # the close pair
        ((-0.5, 0.0, -0.5, 0.0), 0),
    ],
)
def test_count_polynomial(box, expected):
    assert count_zeros(poly, box) == expected


def test_zeros_in_box_finds_all_polynomial_roots():
    roots = zeros_in_box(poly, (-1, 1, -1, 1), scale=1.0)
    found = np.array(sorted((r.value for r in roots), key=lambda z: (z.real, z.imag)))
    expected = np.array(sorted(ROOTS[np.abs(ROOTS.real) < 1], key=lambda z: (z.real, z.imag)))
    assert len(found) == 4
    # Simple roots of a degree-5 polynomial: Newton reaches rounding level (measured ~1e-16).
    np.testing.assert_allclose(found, expected, rtol=0, atol=1e-13)
    assert all(r.converged for r in roots)


def test_meromorphic_counts_zeros_minus_poles():
    def g(z):
        with np.errstate(divide="ignore", invalid="ignore"):
            return (z - 0.1) * (z + 0.2j) * (z - 0.4 + 0.3j) / ((z - 0.5j) * (z + 0.3) ** 2)

    box = (-1, 1, -1, 1)
    assert winding_number(g, box) == 3 - 3
    assert count_zeros(g, box, poles=[0.5j, (-0.3, 2)]) == 3
    roots = zeros_in_box(g, box, poles=[0.5j, (-0.3, 2)])
    np.testing.assert_allclose(
        sorted((r.value for r in roots), key=lambda z: (z.real, z.imag)),
        [-0.2j, 0.1, 0.4 - 0.3j],
        atol=1e-13,
    )


def test_transcendental_many_roots():
    # sin(pi z) has zeros at the integers: 7 of them in (-3.5, 3.5)
    def f(z):
        return np.sin(np.pi * z)

    roots = zeros_in_box(f, (-3.5, 3.5, -0.3, 0.4))
    assert len(roots) == 7
    np.testing.assert_allclose([r.value for r in roots], np.arange(-3, 4), atol=1e-14)


def test_zero_on_contour_is_an_error():
    with pytest.raises(ContourError, match="contour"):
        count_zeros(poly, (0.3, 1.0, -1.0, 1.0))  # edge Re z = 0.3 passes through 0.3+0.2j


def test_pole_on_contour_is_an_error():
    def g(z):
        with np.errstate(divide="ignore", invalid="ignore"):
            return 1.0 / (z - 0.5)

    with pytest.raises(ContourError):
        count_zeros(g, (0.5, 1.0, -1.0, 1.0))
    with pytest.raises(ContourError, match="pole"):
        count_zeros(g, (0.5, 1.0, -1.0, 1.0), poles=[0.5])


def test_polish_reports_failure_without_raising():
    r = polish(lambda z: np.exp(z), 0.0, maxiter=5)  # no zeros at all
    assert not r.converged
    assert r.reason


def test_polish_quality_fields():
    r = polish(poly, 0.24 - 0.55j)
    assert r.converged
    assert abs(r.value - ROOTS[2]) < 1e-14
    assert r.residual < 1e-14
    assert np.isfinite(r.cond) and r.cond > 0


def test_double_root_is_reported_as_cluster():
    roots = zeros_in_box(lambda z: (z - 0.2) ** 2 * (z + 0.5), (-1, 1, -1, 1))
    assert sum(2 if "cluster of 2" in r.reason else 1 for r in roots) == 3


@pytest.mark.serial
@pytest.mark.parametrize("box", [(-0.01, 2.0, -1000.0, 1000.0), (0.0, 1.0, 0.0, 1.0),
                                 (-50.0, 50.0, -0.5, 0.5)])
@pytest.mark.parametrize("n_initial", [8, 32, 3000])
def test_initial_samples_follow_the_side_lengths(box, n_initial):
    """``n_initial`` on the longest side, the others in proportion (at least min(n, 16)), the
    corners among them, evenly spaced per side."""
    from analytic.numerics.roots import _initial_samples

    t = _initial_samples(box, n_initial)
    lengths = [box[1] - box[0], box[3] - box[2]] * 2
    for j, length in enumerate(lengths):
        side = t[(t >= j) & (t < j + 1)]
        want = max(int(np.ceil(n_initial * length / max(lengths))), min(n_initial, 16))
        assert side.size == want and side[0] == j
        assert np.allclose(np.diff(side), 1.0 / want, rtol=0, atol=1e-15)
    assert np.all(np.diff(t) > 0)


@pytest.mark.serial
def test_tall_box_counts_the_same_with_proportional_sides():
    """Roots placed along a tall box, some near its short sides: the count with the
    proportional start equals the number of roots inside, whatever n_initial."""
    rng = np.random.default_rng(3)
    roots = np.concatenate([rng.uniform(0.1, 1.9, 40) + 1j * rng.uniform(-900, 900, 40),
                            [1.0 + 999.9j, 0.5 - 999.95j, 1.5 + 1000.05j]])
    box = (0.0, 2.0, -1000.0, 1000.0)
    inside = sum(1 for r in roots if box[2] < r.imag < box[3])

    def fun(z):  # each zero paired with a pole 3 to its right, outside the box
        zz = np.asarray(z)[..., None]
        return np.prod((zz - roots) / (zz - roots - 3.0), axis=-1)

    for n in (32, 200, 2000):
        assert count_zeros(fun, box, n_initial=n) == inside == 42


def test_a_large_dynamic_range_is_not_a_zero_on_the_contour():
    """A zero on the contour is judged against the median sample, not the largest one.

    ``|F|`` here spans ``exp(-20 .. 20)`` along the contour: a fixed fraction (1e-12) of the
    largest value called ordinary samples zeros. A true zero on an edge is still an error.
    """
    def f(z):
        return (z - 0.25) * np.exp(20.0 * z)

    assert count_zeros(f, (-1.0, 1.0, -1.0, 1.0)) == 1
    with pytest.raises(ContourError, match="vanishes"):
        count_zeros(f, (0.25, 1.0, -1.0, 1.0))


def test_thin_strip_exact_count_closes():
    """det_M at H = 0.01, k = 1 spans 1e-3 .. 4e11 on the 4 c_d box (its weight near the
    origin); the count used to fail there ("function vanishes on the contour"). The roots sit
    next to the dilatational thickness resonances ``beta H omega = (2m + 1) pi / 2``: polished
    from those, the ones in the box are the count and the roots ``zeros_in_box`` locates.
    """
    p = Params(H=0.01)
    box = Region().box(p, 1.0)

    def f(z):
        return det_M(z, 1.0, p)

    w = np.pi / (2 * p.beta * p.H)
    seeds = [0.1 + s * (2 * m + 1) * w * 1j for m in range(3) for s in (-1, 1)]
    polished = [r.value for r in (polish(f, z) for z in seeds) if r.converged]
    inside = {complex(np.round(z, 6)) for z in polished
              if box[0] < z.real < box[1] and box[2] < z.imag < box[3]}
    assert count_zeros(f, box) == len(inside) == 2
    located = [r.value for r in zeros_in_box(f, box)]
    assert len(located) == 2
    assert all(min(abs(z - y) for y in inside) < 1e-5 for z in located)


#: Two zeros inside the tall band (0, 2) x (-50.5, 50.5), and a row of zeros just outside its
#: left edge at -0.01 + i m, m = -50 .. 50 (as the slower roots of the fastest-root search).
BAND_INSIDE = np.array([0.3 + 10.2j, 0.05 - 33.7j])


def _band(z):
    z = np.asarray(z, dtype=complex)
    return np.sin(-1j * np.pi * (z + 0.01)) * (z - BAND_INSIDE[0]) * (z - BAND_INSIDE[1]) / 50.0


@pytest.mark.parametrize("scan", [True, False])
def test_a_tall_band_is_scanned_not_bisected(scan, monkeypatch, count_calls):
    """zeros_in_box on a long box holding <= SCAN_ZEROS zeros: Newton from every dip of |f| at
    once (roots._scan) finds both zeros with the whole box's one count (measured: 1 count);
    bisection finds the same zeros with 21 counts (measured, scan switched off)."""
    from analytic.numerics import roots

    if not scan:
        monkeypatch.setattr(roots, "SCAN_ZEROS", 0)
    found = zeros_in_box(_band, (0.0, 2.0, -50.5, 50.5))
    got = np.array(sorted((r.value for r in found), key=lambda z: z.imag))
    np.testing.assert_allclose(got, sorted(BAND_INSIDE, key=lambda z: z.imag), atol=1e-13)
    assert len(count_calls) == 1 if scan else len(count_calls) > 10


def perimeter_masked(box: tuple[float, float, float, float], t: np.ndarray) -> np.ndarray:
    """``roots._perimeter_point`` as it was before session 25: one masked assignment a side."""
    a, b, c, d = box
    side = np.minimum(np.floor(t).astype(int), 3)
    s = t - side
    z = np.empty(t.shape, dtype=complex)
    m = side == 0
    z[m] = a + s[m] * (b - a) + 1j * c
    m = side == 1
    z[m] = b + 1j * (c + s[m] * (d - c))
    m = side == 2
    z[m] = b - s[m] * (b - a) + 1j * d
    m = side == 3
    z[m] = a + 1j * (d - s[m] * (d - c))
    return z


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_perimeter_points_and_phase_increments_as_before(seed):
    """The contour's points (corner + s edge) equal the masked construction bit for bit, the
    corners and ``t = 4`` included; the wrapped phase increments (a remainder) equal
    ``angle(exp(i x))`` to rounding (measured at most 1.2e-15; 4e-15 allowed) and lie in
    ``[-pi, pi)``."""
    rng = np.random.default_rng(seed)
    for _ in range(100):
        a, c = rng.normal(size=2) * 10
        box = (a, a + rng.uniform(1e-3, 5), c, c + rng.uniform(1e-3, 500))
        t = np.concatenate([rng.uniform(0, 4, 300), [0.0, 1.0, 2.0, 3.0, 4.0]])
        new, old = roots._perimeter_point(box, t), perimeter_masked(box, t)
        assert np.array_equal(new.view(float), old.view(float))
    f = np.exp(1j * rng.uniform(-np.pi, np.pi, 2000)) * rng.uniform(0.1, 2, 2000)
    t = np.sort(rng.uniform(0, 4, 2000))
    dph, _ = roots._increments(f, (0.0, 1.0, 0.0, 1.0), t, np.pi / 3, 0.8, 1e-12)
    ph = np.angle(f)
    ref = np.angle(np.exp(1j * (np.roll(ph, -1) - ph)))
    off = np.abs(dph - ref)
    off = np.minimum(off, 2 * np.pi - off)  # +-pi are the same increment
    assert np.all(off <= 4e-15) and np.all((dph >= -np.pi) & (dph < np.pi))


def _outside_by(w: complex, box: tuple) -> float:
    """Distance from ``w`` to the closed box (0 inside)."""
    return float(np.hypot(max(box[0] - w.real, 0.0, w.real - box[1]),
                          max(box[2] - w.imag, 0.0, w.imag - box[3])))


@pytest.mark.parametrize("start", [1.45 + 1.4j, -0.65 + 0.15j, 0.2 - 0.5j])
@pytest.mark.parametrize("box", [(0.0, 0.5, -0.1, 0.5), (0.0, 1.0, 0.0, 1.0)])
def test_newton_to_a_root_outside_the_box_is_abandoned_early(start, box):
    # session 26: Newton from starts ran to the end for roots outside the box (56 % of the
    # stress map's iterations from starts); roots.polish's `unwanted` stops it once the steps
    # contract and the iterate is farther outside than ABANDON_RADIUS steps
    full = polish(poly, start)
    assert full.converged and not roots._inside(full.value, box)
    cut = polish(poly, start, unwanted=lambda w, r: _outside_by(w, box) > r)
    assert not cut.converged and cut.reason == roots.ABANDONED
    assert cut.iterations < full.iterations
    # what zeros_reached keeps is what full Newton from each start reaches inside the box
    starts = [start, 0.29 + 0.19j, 0.32 + 0.22j, 0.3 + 0.2j, 2.0 + 2.0j]
    kept = sorted((complex(r.value) for r in roots.zeros_reached(poly, box, starts)),
                  key=lambda z: (z.real, z.imag))
    want = sorted({complex(r) for s0 in starts for r in ROOTS
                   if roots._inside(r, box) and abs(polish(poly, s0).value - r) < 1e-9},
                  key=lambda z: (z.real, z.imag))
    assert len(kept) == len(want) >= 2
    assert np.allclose(kept, want, rtol=0, atol=1e-12)


def test_newton_to_a_root_already_found_is_abandoned_early():
    # a second start converging to the root a first one reached: abandoned within 1e-6 of it
    a = polish(poly, 0.28 + 0.18j)
    assert a.converged and abs(a.value - ROOTS[0]) < 1e-12
    b = polish(poly, 0.27 + 0.17j, unwanted=lambda w, r: abs(w - a.value) <= 1e-6)
    assert b.reason == roots.ABANDONED and b.iterations < polish(poly, 0.27 + 0.17j).iterations


@pytest.mark.parametrize("bc", ["stress", "velocity"])
@pytest.mark.parametrize("H,k", [(10.0, 1.0), (3.16, 1.0)])
def test_parts_of_a_bisected_band_take_samples_for_their_own_size(bc, H, k, monkeypatch):
    # session 26: a tall band's parts were counted with the band's n_initial (stress, H = 10,
    # k = 1: 226 715 det_M points for 4 roots); roots._for_part scales it to the part's side
    p = Params(bc=bc, H=H, Delta=-1.0)
    box = (0.015, 2.0, -9.26, 9.26)
    n_init = 8 + int(np.ceil(2 * H * 1.5 * (box[3] - box[2])))
    points = []

    def fun(z):
        points[-1] += np.size(z)
        return det_M(z, k, p)

    found = []
    for scaled in (False, True):
        if not scaled:
            monkeypatch.setattr(roots, "_for_part", lambda kw, outer, part: kw)
        else:
            monkeypatch.undo()
        points.append(0)
        found.append(sorted((complex(r.value) for r in zeros_in_box(fun, box, n_initial=n_init)),
                            key=lambda z: (z.real, z.imag)))
    assert len(found[0]) == len(found[1]) >= 1
    assert np.allclose(found[0], found[1], rtol=1e-12, atol=0)
    assert points[1] < points[0]
