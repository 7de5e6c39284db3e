#!/usr/bin/env bash
# The same tests on an older and a newer commit, back to back on this machine: is the suite slower?
#
#   tests/timing/compare_suite.sh [OLD [NEW]]
#   SUITE_FILES="tests/test_analytic_*.py tests/test_fe_cross_section.py" \
#     tests/timing/compare_suite.sh a578cc5 HEAD
#
# OLD: default a578cc5 (docs/testing.md of "stop 18": 729 + 228 tests, the whole run 4 min 31 s);
# NEW: default HEAD. Both commits are exported (git archive) into $SUITE_WORK (default a new
# temporary folder); the test ids of SUITE_FILES (globs relative to the repository, default
# every tests/test_*.py of OLD) are collected on both, and only the ids present in both are
# run: on OLD, then on NEW, with the Python of PROJECT_VENV (default .venv of this checkout,
# set up by this checkout's ./run first) and the variables ./run exports, not through the
# trees' own ./run (an older ./run would reinstall the shared environment for its own
# requirements). Serial pass: TEST_WORKERS pytest-xdist workers (default 0: one process, less
# noise); SUITE_MPI=1 adds the mpirun -n 2 pass (ids not marked serial), same order. Extra
# pytest options: SUITE_PYTEST (e.g. '-m "not slow"'). SUITE_TOGETHER=1 runs OLD and NEW at
# the same time (each pass of both side by side: on a machine shared with other jobs both see
# the same load; with TEST_WORKERS=0 that is two processes on the two cores). Prints the wall
# times, pytest's last line of each run and the ratio NEW/OLD; $SUITE_WORK/times.txt keeps them.
# The full suite takes about 20 min per commit on 2 idle cores: run it on a quiet machine.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
OLD="${1:-a578cc5}"
NEW="${2:-HEAD}"
export PROJECT_VENV="${PROJECT_VENV:-$HERE/.venv}"
"$HERE/run" python -c "" # the environment of this checkout, installed if missing
# What ./run exports (PYTHONPATH is each tree's own, set in intree).
export PETSC_DIR=/usr/lib/petscdir/petsc-complex SLEPC_DIR=/usr/lib/slepcdir/slepc-complex
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_vader_single_copy_mechanism=none OMPI_MCA_rmaps_base_oversubscribe=1
export OMPI_MCA_orte_execute_quiet=1 MPLBACKEND=Agg PYVISTA_OFF_SCREEN=true
export PATH="$PROJECT_VENV/bin:$PATH" VIRTUAL_ENV="$PROJECT_VENV"
intree() {  # intree <side> command...: run in that tree, its code first on the path
  local side="$1"; shift
  (cd "$WORK/$side" && PYTHONPATH="$WORK/$side" "$@")
}
WORK="${SUITE_WORK:-$(mktemp -d /tmp/compare_suite.XXXXXX)}"
WORKERS="${TEST_WORKERS:-0}"
read -r -a EXTRA <<< "${SUITE_PYTEST:-}"
mkdir -p "$WORK"
echo "old $OLD = $(git -C "$HERE" rev-parse --short "$OLD"), new $NEW = $(git -C "$HERE" rev-parse --short "$NEW"), in $WORK"

for side in old new; do
  rev="$OLD"; [ "$side" = new ] && rev="$NEW"
  rm -rf "${WORK:?}/$side" && mkdir -p "$WORK/$side"
  git -C "$HERE" archive "$rev" | tar -x -C "$WORK/$side"
done

# The files: globs expanded in OLD (the tests that existed then).
cd "$WORK/old"
read -r -a PATTERNS <<< "${SUITE_FILES:-tests/test_*.py}"
FILES=()
for pat in "${PATTERNS[@]}"; do
  for f in $pat; do [ -f "$f" ] && FILES+=("$f"); done
done
[ "${#FILES[@]}" -gt 0 ] || { echo "no test file matches SUITE_FILES in $OLD" >&2; exit 2; }

collect() {  # collect <side> [pytest options] -> ids, one a line
  local side="$1"; shift
  intree "$side" python -m pytest --collect-only -q -p no:cacheprovider "$@" "${FILES[@]}" \
    2>/dev/null | grep '::' || true
}
passes=(serial); [ "${SUITE_MPI:-0}" = 1 ] && passes+=(mpi)
for pass in "${passes[@]}"; do
  select=(); [ "$pass" = mpi ] && select=(-m "not serial")
  collect old "${select[@]}" | sort > "$WORK/ids_old_$pass.txt"
  collect new "${select[@]}" | sort > "$WORK/ids_new_$pass.txt"
  comm -12 "$WORK/ids_old_$pass.txt" "$WORK/ids_new_$pass.txt" > "$WORK/ids_$pass.txt"
  echo "$pass pass: $(wc -l < "$WORK/ids_old_$pass.txt") ids at old," \
       "$(wc -l < "$WORK/ids_new_$pass.txt") at new, $(wc -l < "$WORK/ids_$pass.txt") in both (run)"
done

run_pass() {  # run_pass <side> <pass> -> seconds on stdout, pytest's last line in the log
  local ids log t0 t1
  mapfile -t ids < "$WORK/ids_$2.txt"
  log="$WORK/$1_$2.log"
  t0=$(date +%s.%N)
  if [ "$2" = serial ]; then
    workers=(); [ "$WORKERS" != 0 ] && workers=(-n "$WORKERS" --dist worksteal)
    intree "$1" python -m pytest -q -p no:cacheprovider "${workers[@]}" "${EXTRA[@]}" \
      "${ids[@]}" > "$log" 2>&1 || true
  else
    intree "$1" mpirun -n 2 python -m mpi4py -m pytest -q --color=no -p no:cacheprovider \
      "${EXTRA[@]}" "${ids[@]}" > "$log" 2>&1 || true
  fi
  t1=$(date +%s.%N)
  echo "$t0 $t1" | awk '{printf "%.1f", $2 - $1}'
}

: > "$WORK/times.txt"
for pass in "${passes[@]}"; do
  [ -s "$WORK/ids_$pass.txt" ] || { echo "$pass pass: no common test id" >&2; continue; }
  if [ "${SUITE_TOGETHER:-0}" = 1 ]; then  # both at once: the same machine load for both
    run_pass old "$pass" > "$WORK/t_old" & run_pass new "$pass" > "$WORK/t_new" & wait
    t_old=$(cat "$WORK/t_old"); t_new=$(cat "$WORK/t_new")
  else
    t_old=$(run_pass old "$pass")
    t_new=$(run_pass new "$pass")
  fi
  echo "$pass old: ${t_old} s ($(tail -n 1 "$WORK/old_$pass.log"))" | tee -a "$WORK/times.txt"
  echo "$pass new: ${t_new} s ($(tail -n 1 "$WORK/new_$pass.log"))" | tee -a "$WORK/times.txt"
  echo "$t_old $t_new" | awk -v p="$pass" '{printf "%s new/old = %.3f\n", p, $2 / $1}' \
    | tee -a "$WORK/times.txt"
done
