"""Two commits' stability maps side by side: CPU seconds, and the same counts and values.

    ./run python tests/timing/map_speed.py [--old main] [--new HEAD] [--case NAME ...]

Both commits are exported as in ``sweep_speed.py`` and each case runs
``workflows/stability_map.py`` on one rank from both trees *at the same time* (the same load
for both), with the Python and the environment of this process (run it through ``./run``).
The children's CPU time (user + system, a child's start included) is compared. Then the two
``stability_map.csv`` are compared point by point: the columns that count (``stable_on_grid``,
``unstable_k_count``, ``failed_counts``, ``proven_k_count``, ``c_max_largest``) must be equal,
and the largest relative differences of ``re_lambda`` and of the refined peak's ``k`` are
printed. One line per case; exit 1 if a counted column differs.

Cases (``--case``, default ``default``): ``default`` (the scene's defaults: a 5 x 5 map of
``Delta`` and ``H``, velocity top), ``stress`` (the same, ``--bc stress``), ``readme63`` (the
README's 63-point velocity map, ``--x Delta:-1:1:9 --y H:0.1:10:7log --nk 16``).
"""

from __future__ import annotations

import csv
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from sweep_speed import parser, run_both, trees_of  # noqa: E402

CASES = {
    "default": [],
    "stress": ["--bc", "stress"],
    "readme63": ["--x", "Delta:-1:1:9", "--y", "H:0.1:10:7log", "--nk", "16"],
}
#: Columns that must be equal in both maps.
COUNTED = ("stable_on_grid", "unstable_k_count", "failed_counts", "proven_k_count",
           "c_max_largest")


def start(tree: str, args: list[str], out: str) -> subprocess.Popen:
    """``stability_map.py`` of ``tree`` on one rank, in the background."""
    env = dict(os.environ, PYTHONPATH=tree, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    cmd = [sys.executable, os.path.join(tree, "workflows", "stability_map.py"), *args,
           "--out", out]
    return subprocess.Popen(cmd, cwd=tree, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)


def compare(old: str, new: str) -> tuple[list[str], float, float, int]:
    """``(problems, max rel re_lambda diff, max rel k diff, points)`` of two maps."""
    rows = []
    for out in (old, new):
        with open(os.path.join(out, "stability_map.csv")) as fh:
            rows.append(list(csv.DictReader(fh)))
    ra, rb = rows
    if len(ra) != len(rb):
        return [f"{len(ra)} points vs {len(rb)}"], float("nan"), float("nan"), len(rb)
    problems: list[str] = []
    re_diff = k_diff = 0.0
    for a, b in zip(ra, rb, strict=True):
        for col in COUNTED:
            if a[col] != b[col]:
                problems.append(f"{col} at ({a['x']}, {a['y']}): {a[col]} vs {b[col]}")
        if a["re_lambda"] and b["re_lambda"]:
            ea, eb, ka, kb = (float(r[c]) for c in ("re_lambda", "k") for r in (a, b))
            re_diff = max(re_diff, abs(ea - eb) / abs(ea))
            k_diff = max(k_diff, abs(ka - kb) / abs(ka))
        elif a["re_lambda"] != b["re_lambda"]:
            problems.append(f"re_lambda at ({a['x']}, {a['y']}): {a['re_lambda']!r} vs "
                            f"{b['re_lambda']!r}")
    return problems, re_diff, k_diff, len(rb)


def main() -> int:
    args = parser(__doc__, list(CASES), ["default"]).parse_args()
    work, trees = trees_of(args.old, args.new, "map_speed_")
    bad = 0
    for case in args.case:
        outs = {name: os.path.join(work, f"{case}_{name}") for name in trees}
        cpu, wall = run_both(trees, start, CASES[case], outs)
        problems, re_diff, k_diff, points = compare(outs["old"], outs["new"])
        bad += bool(problems)
        print(f"{case}: old {cpu['old']:.1f} s, new {cpu['new']:.1f} s, ratio "
              f"{cpu['old'] / cpu['new']:.2f}; {points} points, max rel diff re_lambda "
              f"{re_diff:.1e}, k {k_diff:.1e}; "
              + ("; ".join(problems[:5]) if problems else "counted columns equal")
              + f" ({wall:.0f} s wall)", flush=True)
    return int(bad > 0)


if __name__ == "__main__":
    sys.exit(main())
