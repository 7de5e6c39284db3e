"""forms.studies.benchmark: the measurements of workflows/benchmark.py (errors and orders, no
times).

The models live on COMM_SELF: every rank of the mpirun -n 2 pass computes the same numbers.
"""

import numpy as np
import pytest

from forms.studies import benchmark as bench


@pytest.mark.parametrize("degree, cells", [(2, (6, 12)), (3, (3, 6))])
def test_convergence_order_is_2p_at_the_check_point(degree, cells):
    rows = bench.convergence({degree: cells})
    assert [(r["degree"], r["cells"]) for r in rows] == [(degree, c) for c in cells]
    assert np.isnan(rows[0]["order"]) and rows[1]["rel_error"] < rows[0]["rel_error"]
    # eigenvalue error h^(2p): observed 3.99 (P2, 6 -> 12 cells) and 5.95 (P3, 3 -> 6 cells)
    assert rows[1]["order"] == pytest.approx(2 * degree, abs=0.1)


@pytest.mark.serial
def test_speed_reports_errors_of_every_method():
    """Baseline and FE continuation against the certified exact roots on a short grid."""
    k = np.linspace(0.2, 2.0, 8)
    res = bench.speed(k)
    assert res["k"] == [0.2, 2.0, 8] and res["analytic_certified"]["all_ok"]
    # Newton on S converges to the exact roots: measured 1.6e-16 here, 2.4e-16 on 0.05:6:40
    assert res["baseline"]["max_rel_error"] < 1e-12
    fe = res["fe_continuation"]
    assert fe is not None and fe["max_rel_error"] <= bench.FE_TARGET_ERROR
    assert fe["cells"] in bench.FE_CELLS and fe["factorizations_per_point"] >= 1
    # the mesh is the cheapest that meets the target: one cell size fewer does not
    assert fe["cells"] == bench.FE_CELLS[0] or bench.speed(
        k, fe_cells=bench.FE_CELLS[:bench.FE_CELLS.index(fe["cells"])])["fe_continuation"] is None
