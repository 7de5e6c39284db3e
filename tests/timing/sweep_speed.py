"""Two commits' FE-first sweeps side by side: CPU seconds, and the same counts, statuses, values.

    ./run python tests/timing/sweep_speed.py [--old main] [--new HEAD] [--case NAME ...]

Both commits are exported (``git archive``) into a temporary folder and each case runs
``workflows/sweep_k.py --check-exact no --no-plot --quiet`` on one rank from both trees *at the
same time* (two child processes: on a machine shared with other jobs both see the same load),
with the Python and the environment of this process (run it through ``./run``). The children's
CPU time (user + system, ``os.wait4``; a child's start, about 1.5 s of imports, included) is
compared, ``--repeat`` times per case. Then the outputs are compared: the count per ``k``, the
rows' statuses and certificates, and the largest relative difference of the eigenvalues (rows
paired per ``k`` in the order of ``Im``, then ``Re``) and the largest absolute difference of the
error estimates. Prints one line per case; exit 1 if a count, a status or a certificate differs.

Cases (``--case``, default all): ``velocity`` (the default grid, 120 k, adaptive region),
``stress`` (the default grid, ``--c-max 4``), ``stress_auto`` (the default grid, adaptive
region: 8-32 ``c_d``), ``k50`` (``--k 50,51 --c-max 4``, velocity top).
``--new WORKTREE`` times the files of this checkout as they are, uncommitted edits included.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
CASES = {
    "velocity": [],
    "stress": ["--bc", "stress", "--c-max", "4"],
    "stress_auto": ["--bc", "stress"],
    "k50": ["--k", "50,51", "--c-max", "4"],
}


def export(rev: str, dest: str) -> str:
    """The tree of ``rev`` (``WORKTREE``: this checkout's files) under ``dest``; its path."""
    if rev == "WORKTREE":
        return ROOT
    os.makedirs(dest)
    archive = subprocess.run(["git", "-C", ROOT, "archive", rev], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", dest], input=archive, check=True)
    return dest


def start(tree: str, args: list[str], out: str) -> subprocess.Popen:
    """``sweep_k.py`` of ``tree`` on one rank, in the background."""
    env = dict(os.environ, PYTHONPATH=tree, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    cmd = [sys.executable, os.path.join(tree, "workflows", "sweep_k.py"), *args,
           "--check-exact", "no", "--no-plot", "--quiet", "--out", out]
    return subprocess.Popen(cmd, cwd=tree, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)


def wait_all(procs: dict[str, subprocess.Popen]) -> dict[str, float]:
    """Wait for every child; CPU seconds (user + system) of each."""
    cpu, left = {}, {p.pid: name for name, p in procs.items()}
    while left:
        pid, status, usage = os.wait4(-1, 0)
        if pid not in left:
            continue
        name = left.pop(pid)
        procs[name].returncode = os.waitstatus_to_exitcode(status)
        cpu[name] = usage.ru_utime + usage.ru_stime
    for name, p in procs.items():
        if p.returncode not in (0, 1):
            raise RuntimeError(f"{name} failed ({p.returncode}): {p.stderr.read()[-2000:]}")
    return cpu


def read(out: str) -> tuple[list[dict], dict]:
    """Rows of ``spectrum.csv`` and ``summary.json``."""
    with open(os.path.join(out, "spectrum.csv")) as fh:
        rows = list(csv.DictReader(fh))
    with open(os.path.join(out, "summary.json")) as fh:
        return rows, json.load(fh)


def compare(old: str, new: str) -> tuple[list[str], float, float, int]:
    """Differences of two sweeps: ``(problems, max rel value diff, max estimate diff, rows)``."""
    (ra, sa), (rb, sb) = read(old), read(new)
    problems = []
    na, nb = ([d["n_fe"] for d in s["per_k"]] for s in (sa, sb))
    if na != nb:
        problems.append(f"counts differ at {sum(a != b for a, b in zip(na, nb, strict=False))} k")
    for key in ("k_not_closed", "rows_ok", "rows"):
        if sa["certificate"][key] != sb["certificate"][key]:
            problems.append(f"certificate {key}: {sa['certificate'][key]} vs "
                            f"{sb['certificate'][key]}")

    def order(r: dict) -> tuple:
        return float(r["k"]), float(r["im_lambda"]), float(r["re_lambda"])

    ra, rb = sorted(ra, key=order), sorted(rb, key=order)
    if len(ra) != len(rb):
        return problems + [f"{len(ra)} rows vs {len(rb)}"], float("nan"), float("nan"), len(rb)
    value = estimate = 0.0
    for a, b in zip(ra, rb, strict=True):
        if a["k"] != b["k"] or a["status"] != b["status"] or a["certificate"] != b["certificate"]:
            problems.append(f"row at k = {a['k']}: {a['status']!r}/{a['certificate']!r} vs "
                            f"{b['status']!r}/{b['certificate']!r}")
        za, zb = (complex(float(r["re_lambda"]), float(r["im_lambda"])) for r in (a, b))
        value = max(value, abs(za - zb) / abs(za))
        estimate = max(estimate, abs(float(a["error_estimate"]) - float(b["error_estimate"])))
    return problems, value, estimate, len(rb)


def parser(doc: str, cases: list[str], default: list[str]) -> argparse.ArgumentParser:
    """``--old``, ``--new``, ``--case`` (one of ``cases``): the options of both timing scripts."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--old", default="main", help="reference commit (default main)")
    ap.add_argument("--new", default="HEAD", help="commit to time (WORKTREE: this checkout)")
    ap.add_argument("--case", nargs="*", choices=sorted(cases), default=default)
    return ap


def trees_of(old: str, new: str, prefix: str) -> tuple[str, dict[str, str]]:
    """A temporary folder and the two trees exported into it; prints what is compared."""
    work = tempfile.mkdtemp(prefix=prefix)
    trees = {"old": export(old, os.path.join(work, "old")),
             "new": export(new, os.path.join(work, "new"))}
    print(f"old = {old}, new = {new}; one rank each, both at once; CPU s "
          f"(user + system) per run", flush=True)
    return work, trees


def run_both(trees: dict[str, str], starter: object, args: list[str], outs: dict[str, str]
             ) -> tuple[dict[str, float], float]:
    """Both trees' ``starter(tree, args, out)`` at once: CPU seconds of each, wall seconds."""
    t0 = time.perf_counter()
    cpu = wait_all({name: starter(tree, args, outs[name]) for name, tree in trees.items()})
    return cpu, time.perf_counter() - t0


def main() -> int:
    ap = parser(__doc__, list(CASES), list(CASES))
    ap.add_argument("--repeat", type=int, default=1, help="runs per case (default 1)")
    args = ap.parse_args()
    work, trees = trees_of(args.old, args.new, "sweep_speed_")
    bad = 0
    for case in args.case:
        for rep in range(args.repeat):
            outs = {name: os.path.join(work, f"{case}_{rep}_{name}") for name in trees}
            cpu, wall = run_both(trees, start, CASES[case], outs)
            problems, value, estimate, rows = compare(outs["old"], outs["new"])
            bad += bool(problems)
            print(f"{case} run {rep + 1}: old {cpu['old']:.2f} s, new {cpu['new']:.2f} s, "
                  f"ratio {cpu['old'] / cpu['new']:.2f}; {rows} rows, max rel value diff "
                  f"{value:.1e}, max estimate diff {estimate:.1e}; "
                  + ("; ".join(problems) if problems else "counts, statuses equal")
                  + f" ({wall:.0f} s wall)", flush=True)
    return int(bad > 0)


if __name__ == "__main__":
    sys.exit(main())
