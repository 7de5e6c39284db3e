"""The workflows' shared chores (workflows/_cli.py): output folder, lock, provenance, options,
messages, work sharing; and the ``python -m analytic`` command line.

Workflows run as subprocesses (tests/_workflows.py), serially and under ``mpirun -n 2``, with a
timeout: a hang is a failure. Bad-input paths exit before any computation, so they are fast;
the few real runs are tiny. The subprocess tests launch their own mpirun, so they are marked
serial; the in-process RunFolder test runs in both passes (under mpirun it checks that every
rank gets the same verdict).
"""

import csv
import io
import itertools
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time

import pytest
from _workflows import ROOT, run_workflow

sys.path.insert(0, os.path.join(ROOT, "workflows"))
import _cli  # noqa: E402

#: Bad input must be refused before any computation: generous against a loaded machine, but
#: a hang (a rank waiting in a collective forever) still fails.
QUICK = 120
#: Every workflow (benchmark.py runs on one rank only) with a cheap valid argument set.
SCENES = {
    "mode_shape.py": ["--source", "cross-section", "--no-render", "--phases", "1"],
    "finite_block.py": ["--lengths", "2", "--cells-per-unit", "2", "--ny", "2", "--degree", "1",
                        "--targets", "1", "--nev", "2", "--no-kulikovskii", "--k-scan",
                        "0.5:1.5:3"],
    "halfspace_modes.py": ["--k", "0.3", "--degree", "2", "--H-trunc", ""],
    "work_precision.py": ["--tiny", "--repeats", "1", "--no-dense"],
    "strip_benchmark.py": ["--levels", "1", "--nx0", "4", "--ny0", "2"],
    "figures.py": ["--only", "both", "--no-fe", "--n-q", "20"],
    "phase_diagram.py": ["--f", "0.3", "--beta", "0.5", "--n-gamma", "2"],
}
FINITE_BLOCK = SCENES["finite_block.py"]


def _lines(text):
    return [ln for ln in text.replace("\r", "\n").splitlines() if ln.strip()]


def _one_error_line(res, *needles):
    assert res.returncode == 2, res.stderr[-2000:]
    # progress bar states are not messages
    lines = [ln for ln in _lines(res.stderr) if not re.search(r"\d+%\|", ln)]
    assert len(lines) == 1, res.stderr[-2000:]
    assert lines[0].startswith("error:"), lines
    for n in needles:
        assert n in lines[0], lines
    return lines[0]


def _analytic(args, nproc=1):
    return run_workflow(os.path.join("..", "analytic", "__main__.py"), args, nproc, QUICK)


# ------------------------------------------------------------------------- output folder
#: Where the defects were reported under mpirun: these scenes are also run with -n 2.
MPI_SCENES = ("mode_shape.py", "finite_block.py")


#: Every scene serially; under mpirun -n 2 the ones where the defects were reported (the code
#: path, _cli.start / RunFolder, is the same in every scene).
RUNS = ([(s, 1) for s in (*SCENES, "benchmark.py", "sweep_k.py", "envelope.py", "contrast.py",
                          "time_domain.py")]
        + [(s, 2) for s in MPI_SCENES])


@pytest.mark.serial
@pytest.mark.parametrize("script,nproc", RUNS)
def test_out_is_an_existing_file(tmp_path, script, nproc):
    """Was a hang under mpirun (rank 0 raised, rank 1 waited) and a traceback serially."""
    target = tmp_path / "taken"
    target.write_text("not a folder")
    res = run_workflow(script, ["--out", str(target)], nproc, QUICK)
    _one_error_line(res, "--out", "not a folder")
    assert target.read_text() == "not a folder"


@pytest.mark.serial
@pytest.mark.parametrize("script,nproc", [("mode_shape.py", 1), ("finite_block.py", 2)])
def test_out_cannot_be_created(script, nproc):
    """Was: every workflow computed in full, then failed writing."""
    res = run_workflow(script, ["--out", "/proc/no/such/folder"], nproc, QUICK)
    _one_error_line(res, "--out", "cannot be created")


@pytest.mark.serial
@pytest.mark.parametrize("nproc", [1])
def test_out_with_foreign_files_is_refused(tmp_path, nproc):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    res = run_workflow("phase_diagram.py", ["--out", str(out)], nproc, QUICK)
    _one_error_line(res, "notes.txt")
    assert sorted(os.listdir(out)) == ["notes.txt"]


# ------------------------------------------------------------------ lock and provenance
@pytest.mark.serial
@pytest.mark.parametrize("nproc", [2])
def test_lock_of_a_live_run_is_respected(tmp_path, nproc):
    out = tmp_path / "out"
    out.mkdir()
    lock = {"pid": os.getpid(), "host": socket.gethostname(), "time": "now", "command": "x"}
    (out / _cli.LOCK).write_text(json.dumps(lock))
    res = run_workflow("finite_block.py", [*FINITE_BLOCK, "--out", str(out)], nproc, QUICK)
    _one_error_line(res, "in use by another run", f"pid {os.getpid()}")
    assert json.loads((out / _cli.LOCK).read_text()) == lock  # left alone
    assert sorted(os.listdir(out)) == [_cli.LOCK]


@pytest.mark.serial
def test_stale_lock_is_taken_over_and_released(tmp_path):
    dead = subprocess.Popen(["true"])
    dead.wait()
    out = tmp_path / "out"
    out.mkdir()
    (out / _cli.LOCK).write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname()}))
    res = run_workflow("figures.py", [*SCENES["figures.py"], "--out", str(out)], 1, 300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert not (out / _cli.LOCK).exists()
    record = json.loads((out / _cli.RECORD).read_text())
    assert record["scene"] == "figures" and "figures.py" in record["runs"][0]["command"]
    assert "numpy" in record["runs"][0]["versions"]


@pytest.fixture(scope="module")
def finished_block(tmp_path_factory):
    """A tiny finite_block run (beta 0.5) to resume from."""
    out = tmp_path_factory.mktemp("block") / "out"
    res = run_workflow("finite_block.py", [*FINITE_BLOCK, "--out", str(out)], 1, 300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert not (out / _cli.LOCK).exists()
    return out


def _csv_rows(out):
    with open(out / "finite_block.csv") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.serial
@pytest.mark.parametrize("resume,nproc", [(True, 1), (True, 2), (False, 1)])
def test_other_parameters_are_refused(finished_block, nproc, resume):
    """Was: --resume with another --beta silently appended rows of a different problem."""
    before = _csv_rows(finished_block)
    args = [*FINITE_BLOCK, "--beta", "0.6", "--out", str(finished_block)]
    res = run_workflow("finite_block.py", [*args, "--resume"] if resume else args, nproc, QUICK)
    line = _one_error_line(res, "params.beta", "0.5", "0.6")
    assert ("--resume" in line) == resume
    assert _csv_rows(finished_block) == before
    assert not (finished_block / _cli.LOCK).exists()


@pytest.mark.serial
def test_resume_without_record_is_refused(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "finite_block.csv").write_text("L,re_lambda\n2,0.1\n")
    res = run_workflow("finite_block.py", [*FINITE_BLOCK, "--resume", "--out", str(out)], 1,
                       QUICK)
    _one_error_line(res, "--resume", "no run record")


# --------------------------------------------------------------------------- options
@pytest.mark.serial
@pytest.mark.parametrize("nproc", [1, 2])
@pytest.mark.parametrize("script,typo,name", [("mode_shape.py", ["-beta", "0.8"], "-beta"),
                                              ("finite_block.py", ["-k", "3"], "-k"),
                                              ("halfspace_modes.py", ["-pep_type", "linear"],
                                               "-pep_type")])
def test_single_dash_typo_is_refused(tmp_path, script, typo, name, nproc):
    """Was: -beta 0.8 ran with beta 0.5 and exit 0 (the option went to PETSc, unused)."""
    out = tmp_path / "out"
    res = run_workflow(script, [*typo, "--out", str(out)], nproc, QUICK)
    _one_error_line(res, f"option {name}")
    assert not out.exists()


@pytest.mark.serial
@pytest.mark.parametrize("script,nproc", RUNS)
def test_abbreviation_is_refused(tmp_path, script, nproc):
    out = tmp_path / "out"
    res = run_workflow(script, ["--ou", str(out)], nproc, QUICK)
    _one_error_line(res, "--ou")
    assert not out.exists()


@pytest.mark.serial
def test_abbreviation_is_refused_by_analytic():
    _one_error_line(_analytic(["branch", "--k", "1", "--be", "0.4"]), "--be")


@pytest.mark.serial
def test_scene_option_reaches_its_solver(tmp_path):
    """-bench_pep_type is strip_benchmark's: accepted and read by its PEP (a bad value fails)."""
    res = run_workflow("strip_benchmark.py", [*SCENES["strip_benchmark.py"], "-bench_pep_type",
                                              "nonsense", "--out", str(tmp_path / "o")], 1, 300)
    assert res.returncode != 0 and "nonsense" in res.stderr
    res = run_workflow("strip_benchmark.py", [*SCENES["strip_benchmark.py"], "-bench_pep_type",
                                              "toar", "--out", str(tmp_path / "p")], 1, 300)
    assert res.returncode == 0, res.stderr[-2000:]


@pytest.mark.serial
@pytest.mark.parametrize("script,prefixes,nproc", [
    ("finite_block.py", ("block_", "xs_", "kroots_"), 2),
    ("halfspace_modes.py", ("pml_", "trunc_"), 1),
    ("work_precision.py", ("wp_pep_", "wp_nep_"), 1),
    ("figures.py", ("gallery_cs_", "pml_"), 1)])
def test_help_lists_the_prefixes_once(script, prefixes, nproc):
    res = run_workflow(script, ["--help"], nproc, QUICK)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.count("usage:") == 1
    text = " ".join(res.stdout.split())
    for p in prefixes:
        assert f"'{p}'" in text


# ------------------------------------------------------------------- interruptions
def _children(pid):
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout
    return [int(x) for x in out.split()]


@pytest.mark.serial
@pytest.mark.parametrize("nproc", [1, 2])
def test_interrupted_run_says_resume_continues(tmp_path, nproc):
    """Serial: Ctrl-C. mpirun -n 2: one rank killed. Was: silence (exit 137 or 130)."""
    out = tmp_path / "out"
    args = [*FINITE_BLOCK, "--lengths", "2:40:60", "--out", str(out)]
    cmd = [sys.executable, os.path.join(ROOT, "workflows", "finite_block.py"), *args]
    if nproc > 1:
        cmd = ["mpirun", "-n", str(nproc), sys.executable, "-m", "mpi4py", *cmd[1:]]
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PMIX_", "OMPI_COMM_"))}
    env["PYTHONPATH"] = ROOT + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, cwd=ROOT)
    try:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline and proc.poll() is None:
            if (out / "finite_block.csv").exists() and len(_csv_rows(out)) >= 2:
                break
            time.sleep(0.2)
        assert proc.poll() is None, "the run ended before it could be interrupted"
        if nproc == 1:
            proc.send_signal(signal.SIGINT)
        else:
            ranks = [c for c in _children(proc.pid) if "finite_block" in
                     open(f"/proc/{c}/cmdline").read()]
            assert len(ranks) == nproc
            os.kill(max(ranks), signal.SIGKILL)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode != 0, err[-2000:]
    said = [ln for ln in _lines(err) if "--resume" in ln]
    assert len(said) == 1, err[-2000:]
    assert ("stopped by SIGINT (Ctrl-C)" if nproc == 1 else "stopped") in said[0]
    assert str(out) in said[0]
    assert not (out / _cli.LOCK).exists()
    assert len(_csv_rows(out)) >= 2


# ------------------------------------------------------------------------- analytic
@pytest.mark.serial
@pytest.mark.parametrize("nproc", [1, 2])
def test_analytic_bad_input_once(nproc):
    _one_error_line(_analytic(["branch", "--k", "1", "--beta", "0.8"], nproc), "beta")


@pytest.mark.serial
def test_analytic_k_range_gives_the_real_reason():
    """Was: "neither start:stop:count nor a comma list" for a well-formed but empty range."""
    line = _one_error_line(_analytic(["branch", "--k", "2:1:10"]), "--k", "stop")
    assert "neither" not in line


@pytest.mark.serial
def test_analytic_branch_flags_doubtful_rows():
    """Was: NaN rows, no flag column, exit 0 (stress top, gamma = 1e4: branches lost)."""
    res = _analytic(["branch", "--k", "0.5,1", "--bc", "stress", "--gamma", "1e4"])
    assert res.returncode == 1, res.stderr
    rows = list(csv.DictReader(io.StringIO(res.stdout)))
    assert rows and "flag" in rows[0]
    nan_rows = [r for r in rows if r["re_lambda"] == "nan"]
    assert nan_rows and all(r["flag"] for r in nan_rows)
    assert "flagged" in res.stderr


@pytest.mark.serial
@pytest.mark.parametrize("args,needle", [
    (["--H", "1e6"], "k*H = 1e+06 is above 50"),   # was: silent for 120 s
    (["--beta", "1e-6"], "beta = 1e-06 is below"),  # was: silent for 120 s
    (["--k", "1,,2"], "empty item"),                # was: read as 1,2
])
def test_analytic_limits_and_malformed_lists(args, needle):
    """Issue 18: refused in one line before any work (limits measured in analytic/cli.py)."""
    argv = ["branch", "--k", "1", *args] if args[0] != "--k" else ["branch", *args]
    t0 = time.monotonic()
    _one_error_line(_analytic(argv), needle)
    assert time.monotonic() - t0 < QUICK


@pytest.mark.serial
def test_analytic_negative_value_after_option(capsys):
    """``--Delta -1e6`` is a value, as in the workflows (was: an argparse error)."""
    from analytic.cli import attach_negative_values

    assert attach_negative_values(["branch", "--Delta", "-1e6", "--k", "1"]) == [
        "branch", "--Delta=-1e6", "--k", "1"]
    assert attach_negative_values(["-x", "-1"]) == ["-x", "-1"]


@pytest.mark.serial
@pytest.mark.parametrize("script,args,needle", [
    ("sweep_k.py", ["--k", "1", "--H", "1e-9"], "region's height"),  # was: ContourError
    ("sweep_k.py", ["--k", "1e9"], "region's height"),              # was: silent 150 s
    ("sweep_k.py", ["--k", "1", "--Delta", "-1e6"], "Delta = -1e+06"),  # was: silent 150 s
    ("sweep_k.py", ["--k", "55", "--H", "1"], "roots"),             # W H = 453 > 420
    ("time_domain.py", ["--H", "1e-9"], "mesh"),  # was: run.json left before exit 2
    ("envelope.py", ["--k", "1e7"], "region's height"),  # was: silent (W = 8e7)
    ("contrast.py", ["--k", "0.1:300:3log"], "region's height"),  # W = 2425 > 1700
    ("mode_shape.py", ["--k", "1e7"], "k*H = 5e+06"),  # was: silent for more than 200 s
    ("halfspace_modes.py", ["--k", "1e7"], "truncated strip"),  # was: 21.6 GB, then killed
    ("finite_block.py", ["--lengths", "1e6"], "unknowns"),  # was: a 10^9-unknown mesh
    ("friction_patch.py", ["--length", "1e6", "--lp", "1"], "unknowns"),
    ("methods_chart.py", ["--k", "1e7"], "region's height"),
])
def test_scene_limits_refused_before_any_file(tmp_path, script, args, needle):
    """Validation by what the solver can do: one line, exit 2, no run.json, no lock."""
    out = tmp_path / "out"
    _one_error_line(run_workflow(script, [*args, "--out", str(out)], 1, QUICK), needle)
    assert not (out / _cli.RECORD).exists() and not (out / _cli.LOCK).exists()


@pytest.mark.serial
def test_resume_of_a_missing_folder_is_an_error(tmp_path):
    """Was: --resume on a folder that does not exist started from scratch silently."""
    out = tmp_path / "nowhere"
    _one_error_line(run_workflow("sweep_k.py", ["--k", "1", "--resume", "--out", str(out)], 1,
                                 QUICK), "--resume", "does not exist")
    assert not out.exists()


@pytest.mark.serial
def test_block_size_limit_admits_the_readme_table_and_refuses_beyond():
    """The README's largest block (L = 128, 8 cells per unit and 8 in y, P2) is admitted."""
    _cli.check_block_size(128, 8, 8, 2)  # 69 666 unknowns
    with pytest.raises(_cli.ParameterError, match="69 666|unknowns"):
        _cli.check_block_size(128, 8, 8, 2, two_body=True)  # twice that
    with pytest.raises(_cli.ParameterError, match="unknowns"):
        _cli.check_block_size(256, 8, 8, 2)


@pytest.mark.serial
def test_grid_with_an_empty_item_is_an_error():
    with pytest.raises(_cli.ParameterError, match="empty item"):
        _cli.parse_grid("1,,2")
    with pytest.raises(_cli.ParameterError, match="empty item"):
        _cli.parse_k("1,2,")


@pytest.mark.serial
def test_png_metadata_has_the_full_command_and_versions(monkeypatch):
    """Every PNG: command with mpirun -n N, parameters and versions as strict JSON."""
    monkeypatch.setenv("OMPI_COMM_WORLD_SIZE", "2")
    monkeypatch.setattr(_cli, "world_size", lambda: 2, raising=False)
    import _provenance

    monkeypatch.setattr(_provenance, "world_size", lambda: 2)
    meta = _cli.png_metadata({"mu2": float("inf"), "x": float("nan")}, "t")
    assert meta["Description"].startswith("mpirun -n 2 ")
    assert json.loads(meta["Comment"]) == {"mu2": "inf", "x": None}
    assert "dolfinx" in json.loads(meta["Software"].split(" ", 1)[1])


# ---------------------------------------------------------------- in-process helpers
@pytest.mark.serial
@pytest.mark.parametrize("size", [1, 2, 3])
@pytest.mark.parametrize("n", [0, 1, 5, 7])
def test_share_by_cost_is_lpt(size, n):
    costs = [((7 * i) % 5) + 1.0 for i in range(n)]
    share = _cli.share_by_cost(costs, size)
    assert sorted(i for part in share for i in part) == list(range(n))
    assert share == _cli.share_by_cost(costs, size)  # deterministic: every rank agrees
    loads = [sum(costs[i] for i in part) for part in share]
    best = min((max(sum(c for c, r in zip(costs, a, strict=True) if r == q)
                    for q in range(size)) for a in itertools.product(range(size), repeat=n)),
               default=0.0)
    assert max(loads, default=0.0) <= 4 / 3 * best + 1e-12  # Graham's bound for LPT


@pytest.mark.parametrize("slow_rank", [0, 1])
@pytest.mark.parametrize("n", [0, 1, 9])
def test_claim_shared_gives_each_index_once_and_the_free_rank_takes_more(n, slow_rank):
    """Under mpirun -n 2 the rank that is slower per index takes fewer indices."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    mine = []
    for i in _cli.claim_shared(comm, n):
        mine.append(i)
        time.sleep(0.2 if comm.rank == slow_rank else 0.01)
    every = comm.allgather(mine)
    assert sorted(i for part in every for i in part) == list(range(n))
    assert all(part == sorted(part) for part in every)  # claimed in order
    if comm.size == 2 and n == 9:  # 0.2 s against 0.01 s per index: the slow rank takes 1 or 2
        assert len(every[slow_rank]) <= 2 < len(every[1 - slow_rank])


@pytest.mark.parametrize("slow_rank", [0, 1])
@pytest.mark.parametrize("n", [0, 1, 2, 9])
def test_end_claims_give_each_index_once_in_runs_and_the_free_rank_takes_more(n, slow_rank):
    """Under mpirun -n 2 rank 0 takes a run upwards from 0, rank 1 a run downwards from n - 1,
    and the slower rank per index takes fewer."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    claims = _cli.EndClaims(comm, n)
    mine = []
    for i in claims:
        mine.append(i)
        assert 0 < claims.claimed <= n
        time.sleep(0.2 if comm.rank == slow_rank else 0.01)
    every = comm.allgather(mine)
    assert sorted(i for part in every for i in part) == list(range(n))
    if comm.size == 1:
        assert mine == list(range(n))
    else:
        assert every[0] == list(range(len(every[0])))  # from the low end, upwards
        assert every[1] == list(range(n - 1, n - 1 - len(every[1]), -1))  # from the high end
    if comm.size == 2 and n == 9:  # 0.2 s against 0.01 s per index: the slow rank takes 1 or 2
        assert len(every[slow_rank]) <= 2 < len(every[1 - slow_rank])


@pytest.mark.serial
@pytest.mark.parametrize("size", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("n", [0, 1, 7, 40])
def test_end_claims_blocks_cover_every_index_once_by_cost(size, n):
    """One block per pair of ranks (a lone last rank of an odd size gets half a pair's cost):
    consecutive, covering ``0 .. n-1``; each block's cost within one index's cost of its share."""
    from _sharing import _blocks

    costs = [1.0 + (i % 3) for i in range(n)]
    blocks = _blocks(costs, size)
    assert len(blocks) == (size + 1) // 2
    assert blocks[0][0] == 0 and blocks[-1][1] == n
    assert all(a[1] == b[0] for a, b in zip(blocks[:-1], blocks[1:], strict=True))
    weights = [2.0] * (size // 2) + [1.0] * (size % 2)
    for (lo, hi), w in zip(blocks, weights, strict=True):
        share = sum(costs) * w / sum(weights)
        if len(blocks) > 1 and n >= 7:
            assert abs(sum(costs[lo:hi]) - share) <= 2 * max(costs)


@pytest.mark.serial
def test_split_keeps_values_with_their_options():
    p = _cli.make_parser("x", ("strip_",))
    p.add_argument("--target", type=complex)
    p.add_argument("--flag", action="store_true")
    mine, petsc = _cli.split_petsc(p, ["--target", "-0.3-6j", "-strip_pep_ncv", "40", "--flag",
                                       "-log_view", "-strip_st_type", "sinvert"])
    assert mine == ["--target=-0.3-6j", "--flag"]
    assert petsc == ["-strip_pep_ncv", "40", "-log_view", "-strip_st_type", "sinvert"]
    _cli.check_petsc_options(p, petsc)
    with pytest.raises(_cli.ParameterError, match="-xs_pep_nev"):
        _cli.check_petsc_options(p, ["-xs_pep_nev", "3"])


def test_run_folder_verdict_is_collective(tmp_path):
    """Every rank raises the same error (rank 0 decides), none waits: no hang under mpirun."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    base = comm.bcast(str(tmp_path), root=0)
    taken = os.path.join(base, "file")
    if comm.rank == 0:
        with open(taken, "w") as fh:
            fh.write("x")
    comm.Barrier()
    with pytest.raises(_cli.ParameterError) as err:
        _cli.RunFolder(comm, taken, "t", {"a": 1}).open()
    assert comm.allgather(str(err.value)) == [str(err.value)] * comm.size
    out = os.path.join(base, "out")
    with _cli.RunFolder(comm, out, "t", {"a": 1}) as run:
        assert os.path.exists(run.file(_cli.LOCK))
        if comm.rank == 0:  # a second run on the same folder, while this one holds it
            with pytest.raises(_cli.ParameterError, match="in use by another run"):
                _cli.RunFolder(MPI.COMM_SELF, out, "t", {"a": 1}).open()
        comm.Barrier()
    comm.Barrier()
    assert not os.path.exists(os.path.join(out, _cli.LOCK))
    with pytest.raises(_cli.ParameterError, match="a = 1 there, 2 now"):
        _cli.RunFolder(comm, out, "t", {"a": 2}, resume=True).open()
    with _cli.RunFolder(comm, out, "t", {"a": 1}, resume=True) as run:
        assert run.resumed



@pytest.mark.serial
@pytest.mark.parametrize("analytic_ratio, missed", [(50.0, True), (5.0, False)])
def test_benchmark_targets_flag_a_miss(analytic_ratio, missed):
    """A ratio above its target is a missed target (benchmark.py exits 1 when any is missed)."""
    from forms.studies import benchmark as bench

    ratios = {"analytic_certified_over_baseline": analytic_ratio, "fe_over_baseline": 2.0,
              "target_analytic": 10.0, "target_fe": 20.0}
    targets = bench.all_targets({"speed": {"ratios": ratios}})
    assert any(not t["met"] for t in targets) == missed
    assert sum(not t["met"] for t in targets) == (1 if missed else 0)


def _bar_states(stderr):
    """Every state a tqdm bar printed (split at its carriage returns and newlines)."""
    return [s for s in stderr.replace("\r", "\n").splitlines() if "|" in s]


@pytest.mark.serial
@pytest.mark.slow
def test_sweep_progress_rate_is_in_k_values(tmp_path):
    """sweep_k's bar counts "k values" (e.g. "1.21s/ k values"), never tqdm's "it" or "2.13k/s".

    Its first output is the bar of the region bound per k (about 0.4 s a k value serially:
    before, 120 k values were 47 s of silence (measured) and 500 were 197 s).
    """
    res = run_workflow("sweep_k.py", ["--k", "1,2", "--no-plot", "--out", str(tmp_path / "s")])
    assert res.returncode == 0, res.stderr[-2000:]
    first, rest = res.stderr.lstrip().split("\n", 1)
    # an estimate up front (forms.studies.sweep.estimate_seconds), then the region bound's bar
    assert re.fullmatch(r"plan: 2 k value\(s\) on 1 rank\(s\), about \d+ s of solving .*",
                        first), first
    assert rest.lstrip().startswith("region bound (rank 0 of 1):   0%"), rest[:500]
    states = [s for s in _bar_states(res.stderr) if s.startswith("k values")]
    assert states and all(re.search(r"( k values/s|s/ k values)\]$", s) for s in states), states
    assert not re.search(r"\d(it|k)/s", res.stderr), res.stderr[-2000:]


@pytest.mark.serial
@pytest.mark.parametrize("script,args,desc", [
    ("envelope.py", ["--k", "1,2", "--refine-rounds", "0"], "k values"),
    ("stability_map.py", ["--x", "Delta:-0.5:2:2", "--y", "gamma:0.1:1:2", "--H", "1",
                          "--kH-max", "1", "--nk", "2"], "map points"),
])
def test_long_scenes_show_progress(tmp_path, script, args, desc):
    """envelope.py and stability_map.py: a bar from the first item (before: silent to the end)."""
    res = run_workflow(script, [*args, "--out", str(tmp_path / "o")], 1, QUICK)
    assert res.returncode == 0, res.stderr[-2000:]
    states = [s for s in _bar_states(res.stderr) if s.startswith(desc)]
    assert states and " 0/" in states[0], res.stderr[-2000:]


@pytest.mark.serial
@pytest.mark.slow  # measured 26 s on the loaded machine
def test_contrast_shows_progress(tmp_path):
    """contrast.py: a bar over its (mu2, H2) cases from the start (before: minutes of silence,
    e.g. more than 5 minutes for --mu2-grid 1000000 --H2s H on the loaded machine)."""
    res = run_workflow("contrast.py", ["--mu2-grid", "3", "--H2s", "H", "--k", "1",
                                       "--out", str(tmp_path / "c")])
    assert res.returncode == 0, res.stderr[-2000:]
    states = [s for s in _bar_states(res.stderr) if s.startswith("(mu2, H2) cases")]
    assert states and " 0/1 " in states[0] and " 1/1 " in states[-1], res.stderr[-2000:]


@pytest.mark.serial
@pytest.mark.slow
def test_time_domain_bar_ends_at_100_percent(tmp_path):
    """19 steps (fewer than the 50 per bar update): the last bar state still reads 100 %."""
    res = run_workflow("time_domain.py", ["--cells-per-wavelength", "16", "--ny", "4",
                                          "--amplitude", "1e-6", "--chunk", "20", "--t-end", "1",
                                          "--out", str(tmp_path / "t")])
    assert res.returncode == 0, res.stderr[-2000:]
    last = _bar_states(res.stderr)[-1]
    assert " 100%|" in last and re.search(r" (\d+)/\1 ", last), last


def _strict_constant(name):
    raise ValueError(f"non-strict JSON constant {name}")


@pytest.mark.serial
@pytest.mark.slow
def test_every_json_of_a_run_is_strict(tmp_path):
    """--check-exact no leaves NaN exact values in raw/k*.json: written as null, read back."""
    out = tmp_path / "s"
    res = run_workflow("sweep_k.py", ["--k", "1", "--quiet", "--no-plot", "--check-exact", "no",
                                      "--out", str(out)])
    assert res.returncode == 0, res.stderr[-2000:]
    files = sorted(out.rglob("*.json"))
    assert any(f.parent.name == "raw" for f in files), files
    for f in files:
        json.loads(f.read_text(), parse_constant=_strict_constant)
    raw = json.loads((out / "raw" / "k00000.json").read_text())
    assert raw["rows"] and all(r["re_lambda_exact"] is None for r in raw["rows"])
    with open(out / "spectrum.csv") as fh:  # the NaN came back as NaN (as before the change)
        rows = list(csv.DictReader(fh))
    assert rows and all(r["re_lambda_exact"] == "nan" for r in rows), rows


@pytest.mark.serial
@pytest.mark.parametrize("reference", [False, True])
def test_versions_name_the_blas_actually_loaded(reference):
    """Provenance names the BLAS/LAPACK the process loaded: OpenBLAS (./run installs it and
    Debian's alternatives prefer it), or the reference BLAS when a user points the loader at it."""
    env = dict(os.environ)
    if reference:
        if not os.path.isdir("/usr/lib/x86_64-linux-gnu/blas"):
            pytest.skip("Debian's reference BLAS (libblas3) is not installed")
        env["LD_LIBRARY_PATH"] = "/usr/lib/x86_64-linux-gnu/blas:/usr/lib/x86_64-linux-gnu/lapack"
    code = "from analytic.cli import versions; print(versions()['blas'])"
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=120, check=True)
    libs = res.stdout.strip()
    if reference:
        assert "/blas/libblas.so" in libs and "openblas" not in libs, libs
    else:
        assert "openblas" in libs, libs
