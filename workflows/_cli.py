"""The workflows' shared chores (not physics), one import for the scenes: ``import _cli``.

Every workflow ``workflows/<scene>.py`` follows the same pattern::

    import _cli                      # first of the project's imports (puts the root on sys.path)

    PETSC_PREFIXES = ("strip_", "xs_")   # options prefixes of every SLEPc object the scene uses

    def build_parser():
        p = _cli.make_parser(__doc__, PETSC_PREFIXES)   # no abbreviations, one-line errors
        ...
        return p

    def main(comm=None, argv=None) -> int:
        args, comm = _cli.start(build_parser(), argv, comm)  # parse, PETSc options, JIT quiet
        params = validate(args)                              # ParameterError -> exit 2
        with _cli.RunFolder(comm, args.out, "scene", {"params": ...},
                            resume=args.resume, outputs=("*.csv", "*.png")) as run:
            ...  # compute; _cli.write_json / atomic_open / save_figure into run.file("x")
        return 0

    if __name__ == "__main__":
        _cli.run(main)

This module only puts the project root on ``sys.path`` and re-exports the support modules,
one job each (docs/workflows.md):

- :mod:`_options`: parser rules and the PETSc/SLEPc option filter (:func:`make_parser`,
  :func:`start`, :func:`split_petsc`, :func:`check_petsc_options`);
- :mod:`_grids`: :func:`parse_grid`, the solver limits, :func:`block_unknowns`,
  :func:`require_finite_heights`;
- :mod:`_provenance`: :func:`command`, :func:`versions`, :func:`png_metadata`, strict JSON
  (:func:`dumps`: NaN -> null, inf -> "inf");
- :mod:`_sharing`: :func:`rank`, :func:`say`, :func:`say_plan`, :func:`share_by_cost`,
  :func:`map_shared`, :func:`claim_shared` (work taken by whichever rank is free),
  :class:`EndClaims` (runs of consecutive indices, taken from both ends);
- :mod:`_writing`: whole-or-nothing output files (:func:`atomic_open`, :func:`write_json`,
  :func:`save_figure`, :func:`atomic_files`);
- :mod:`_runfolder`: :class:`RunFolder` (checks, lock, record, ``--resume``);
- :mod:`_parts`: :class:`Parts`, the one resume mechanism (finished pieces of work saved whole,
  loaded back by ``--resume``);
- :mod:`_supervise` (+ :mod:`_watcher`): :func:`run`, how a run ends (one line, exit code).

Also re-exported from :mod:`analytic.cli`: :func:`add_param_arguments`,
:func:`params_from_args`, :func:`parse_k`, :func:`positive_int`.
"""

from __future__ import annotations

import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

# ruff: noqa: E402, F401 - re-exports, after the sys.path line above
from _grids import (
    ROOTS_W_MAX,
    SWEEP_DELTA_MAX,
    SWEEP_W_MAX,
    SWEEP_WH_MAX,
    block_unknowns,
    check_block_size,
    check_branch_kh,
    check_roots_region,
    check_section_options,
    check_sweep_limits,
    parse_grid,
    progress_mapper,
    proof_clause,
    region_from_args,
    require_finite_heights,
)
from _options import (
    PETSC_FAMILIES,
    PETSC_GLOBAL,
    check_petsc_options,
    insert_petsc_options,
    make_parser,
    split_petsc,
    start,
)
from _parts import Parts
from _provenance import (
    add_png_metadata,
    command,
    dumps,
    json_dump,
    json_safe,
    png_metadata,
    versions,
)
from _runfolder import LOCK, LOCK_GRACE, RECORD, RunFolder
from _sharing import (
    EndClaims,
    claim_shared,
    map_shared,
    my_share,
    plan_line,
    quiet_jit,
    rank,
    say,
    say_plan,
    share_by_cost,
    world_size,
)
from _supervise import EXIT_FAILED, EXIT_USAGE, run
from _writing import atomic_files, atomic_open, is_no_space, save_figure, write_json

from analytic.cli import (
    OneLineParser,
    add_param_arguments,
    params_from_args,
    parse_k,
    positive_int,
)
from analytic.params import ParameterError, Params, check_k

# A scene run as a script: its watcher from the first second (a rank killed while importing
# dolfinx is reported too); not when a test or a tool imports _cli.
if sys.argv and os.path.dirname(os.path.abspath(sys.argv[0])) == os.path.dirname(
        os.path.abspath(__file__)):
    from _supervise import start_watcher

    start_watcher()
