"""Fuzzing of every command line (issue 18): parameters and option strings over and beyond range.

Property: a result, a flagged result (exit 1), or one line and exit 2, within a stated time,
never a traceback. Strategies (hypothesis) draw numbers from the whole float line (0, tiny,
huge, negative, ``nan``, ``inf``, ``1e999``), malformed grids (``1,,2``, ``2:1:10``, ``:``) and
option strings (typos, single-dash names, negative values after an option).

- In-process (fast): ``python -m analytic`` (``units`` and ``gr`` run; ``branch`` and
  ``dispersion`` up to the solver, which is replaced by a stub that records that validation
  let the input through) and the scenes' shared parsing (``_cli``: parser, grids, parameters,
  the sweep's solver limits).
- Subprocess (a few per scene): the real scripts, each within :data:`SCENE_SECONDS`.

The suite keeps a fast campaign; ``FUZZ_SCALE=25 FUZZ_SCENE_SCALE=3`` runs a large one (README,
"Reliability").
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import subprocess
import sys
import time
import warnings
from unittest import mock

import numpy as np
import pytest
from _workflows import ROOT

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, example, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

sys.path.insert(0, os.path.join(ROOT, "workflows"))
import _cli  # noqa: E402
from test_faults import SCENES as CHEAP  # noqa: E402

from analytic import cli as acli  # noqa: E402
from analytic.numerics.spectrum import Region  # noqa: E402

SCALE = int(os.environ.get("FUZZ_SCALE", "1"))
#: Examples per scene in the subprocess campaign: 2 * FUZZ_SCENE_SCALE (default FUZZ_SCALE).
SCENE_SCALE = int(os.environ.get("FUZZ_SCENE_SCALE", str(SCALE)))
#: A scene run that passes validation may compute: the largest allowed sweep takes about a
#: minute per k value (workflows/_grids.py); the subprocess cases stay within this bound.
SCENE_SECONDS = 240

SPECIAL = ["0", "-0", "1e-300", "1e-9", "1e9", "1e300", "1e999", "-1e6", "nan", "inf", "-inf",
           "", "abc", "1,,2", "2:1:10", ":", "1:2:0", "0.5:6:3log", "1e9:1e10:3", "3j"]


def numbers() -> st.SearchStrategy[str]:
    """Numbers as the user types them, over and beyond every range."""
    return st.one_of(
        st.sampled_from(SPECIAL),
        st.floats(allow_nan=True, allow_infinity=True).map(repr),
        st.floats(-1e3, 1e3).map(lambda x: f"{x:g}"),
        st.integers(-10, 10**6).map(str))


def grids() -> st.SearchStrategy[str]:
    """k grids: lists, ranges, geometric ranges, malformed ones."""
    return st.one_of(
        numbers(),
        st.lists(numbers(), min_size=1, max_size=4).map(",".join),
        st.tuples(numbers(), numbers(), numbers()).map(":".join),
        st.tuples(numbers(), numbers(), st.integers(-2, 10**6)).map(
            lambda t: f"{t[0]}:{t[1]}:{t[2]}log"))


PARAMS = ["--f", "--gamma", "--beta", "--Delta", "--H", "--alpha-pc", "--alpha-ld", "--mu2",
          "--rho2", "--beta2", "--H2"]
JUNK = ["--bta", "-beta", "--be", "-k", "--k", "-pep_type", "--", "-", "--bc", "--bc2"]


def option_lists(names: list[str]) -> st.SearchStrategy[list[str]]:
    """``[--name value, ...]`` with values from :func:`numbers`, plus junk tokens."""
    pair = st.tuples(st.sampled_from(names), numbers()).map(list)
    junk = st.sampled_from(JUNK).map(lambda t: [t])
    return st.lists(st.one_of(pair, pair, pair, junk), max_size=5).map(
        lambda parts: [tok for part in parts for tok in part])


def _strict(text: str) -> object:
    def bad(name: str) -> None:
        raise AssertionError(f"non-standard JSON constant {name} in {text[:200]}")

    return json.loads(text, parse_constant=bad)


class _ReachedSolver(Exception):
    pass


def _run_analytic(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    stub = mock.Mock(side_effect=_ReachedSolver)
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
            mock.patch("analytic.numerics.branches.follow_branches", stub), \
            mock.patch("analytic.writers.write_dispersion", stub), \
            warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # a warning would be stderr noise
        try:
            code = acli.main(argv)
        except _ReachedSolver:
            code = -1  # validation let it through to the solver
    return code, out.getvalue(), err.getvalue()


def _check_outcome(code: int, out: str, err: str) -> None:
    assert "Traceback" not in err
    if code == 2:
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("error: "), err
        assert out == ""
    else:
        assert code in (-1, 0, 1), (code, err)


FUZZ = settings(max_examples=40 * SCALE, deadline=None, derandomize=SCALE == 1,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


# ------------------------------------------------------------------------- python -m analytic
@pytest.mark.serial
@FUZZ
@given(cmd=st.sampled_from(["branch", "dispersion"]), k=grids(), opts=option_lists(
    PARAMS + ["--branches"]))
def test_analytic_branch_validation(cmd, k, opts):
    """branch / dispersion: one line and exit 2, or validated input handed to the solver."""
    argv = [cmd, f"--k={k}", *opts] + (["--out", os.devnull + "-dir"] if cmd == "dispersion"
                                       else [])
    code, out, err = _run_analytic(argv)
    _check_outcome(code, out, err)


@pytest.mark.serial
@FUZZ
@given(opts=option_lists(["--mu", "--nu", "--rho", "--sigma0", "--v0", "--D", "--f", "--a",
                          "--b", "--H-m", "--mu-sub", "--nu-sub", "--rho-sub", "--H-sub-m"]))
def test_analytic_units(opts):
    """units: strict JSON, or one line and exit 2."""
    code, out, err = _run_analytic(["units", *opts])
    _check_outcome(code, out, err)
    if code == 0:
        _strict(out)


@pytest.mark.serial
@FUZZ
@given(mu2=numbers(), opts=option_lists(["--rho2", "--beta", "--beta2"]))
@example(mu2="1e-300", opts=[])  # found by the large campaign: right answer, overflow warnings
def test_analytic_gr(mu2, opts):
    """gr: strict JSON, or one line and exit 2."""
    code, out, err = _run_analytic(["gr", f"--mu2={mu2}", *opts])
    _check_outcome(code, out, err)
    if code == 0:
        _strict(out)


# ------------------------------------------------------------------------ the scenes' parsing
def _scene_parser() -> object:
    p = _cli.make_parser("a fuzzed scene", petsc=False)
    p.add_argument("--k", default="1")
    p.add_argument("--out", default="x")
    p.add_argument("--resume", action="store_true")
    p.add_argument("--c-max", type=float, default=4.0)
    _cli.add_param_arguments(p)
    return p


@pytest.mark.serial
@FUZZ
@given(k=grids(), opts=option_lists(PARAMS + ["--c-max"]))
def test_scene_parsing_and_limits(k, opts):
    """make_parser + parameters + grids + the sweep's limits: valid values or one ParameterError.

    What passes is inside every stated limit (so the run ends within its stated bound).
    """
    try:
        args, _ = _cli.start(_scene_parser(), [f"--k={k}", *opts], comm=object())
        params = _cli.params_from_args(args)
        grid = _cli.parse_grid(args.k)
        region = Region(c_max=args.c_max)
        if math.isfinite(params.H):
            _cli.check_sweep_limits(params, grid, region)
    except _cli.ParameterError as err:
        msg = str(err)
        assert msg and "\n" not in msg
        return
    assert np.all(np.isfinite(grid)) and np.all(grid > 0) and np.all(np.diff(grid) > 0)
    if math.isfinite(params.H):
        assert region.im_max(params, grid.max()) <= _cli.SWEEP_W_MAX
        assert abs(params.Delta) <= _cli.SWEEP_DELTA_MAX


@pytest.mark.serial
@FUZZ
@given(obj=st.recursive(st.one_of(st.floats(), st.integers(), st.none(), st.text(max_size=3)),
                        lambda c: st.one_of(st.lists(c, max_size=3),
                                            st.dictionaries(st.text(max_size=3), c, max_size=3)),
                        max_leaves=10))
def test_json_is_always_strict(obj):
    """Any value goes out as standard JSON (NaN -> null, inf -> "inf")."""
    _strict(_cli.dumps(obj))


# ------------------------------------------------------------------------ the real scripts
#: Cheap arguments of each scene (test_faults.SCENES), before the drawn ones.
SCENES = {**CHEAP, "benchmark.py": ["--k", "1", "--sweep-k", "1,2", "--skip-mpi"]}


def _run_scene(script: str, argv: list[str], out: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PMIX_", "OMPI_COMM_"))}
    env["PYTHONPATH"] = ROOT + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, os.path.join(ROOT, "workflows", script), *argv, "--out", out]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=SCENE_SECONDS, cwd=ROOT,
                          env=env)


@pytest.mark.serial
@pytest.mark.slow  # 15 scenes x 2 examples x 3-12 s
@pytest.mark.parametrize("script", sorted(SCENES))
def test_scene_command_lines(tmp_path_factory, script):
    """Each scene with drawn parameters and options: a result or one line, no traceback.

    At least one value is out of its range in the suite's campaign (so each case ends at
    validation, 3-5 s); ``FUZZ_SCALE > 1`` also draws fully valid sets, which then compute.
    """
    bad = st.sampled_from(["nan", "-1", "1e999", "0", "abc", "-inf"])

    @settings(max_examples=2 * SCENE_SCALE, deadline=None, derandomize=SCENE_SCALE == 1,
              suppress_health_check=list(HealthCheck))
    @given(opts=option_lists(PARAMS), name=st.sampled_from(PARAMS), value=bad,
           valid=st.booleans() if SCENE_SCALE > 1 else st.just(False))
    def case(opts, name, value, valid):
        out = str(tmp_path_factory.mktemp("fuzz") / "out")
        argv = [*SCENES[script], *opts] if valid else [*SCENES[script], *opts, name, value]
        start = time.monotonic()
        res = _run_scene(script, argv, out)
        assert time.monotonic() - start < SCENE_SECONDS
        assert "Traceback" not in res.stderr, (argv, res.stderr[-2000:])
        assert res.returncode in (0, 1, 2), (argv, res.returncode, res.stderr[-2000:])
        if res.returncode == 2:
            lines = [ln for ln in res.stderr.replace("\r", "\n").splitlines() if ln.strip()]
            assert len(lines) == 1 and lines[0].startswith("error: "), (argv, res.stderr)
            assert not os.path.exists(os.path.join(out, _cli.RECORD)), argv
            assert not os.path.exists(os.path.join(out, _cli.LOCK)), argv

    case()
