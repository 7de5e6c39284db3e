"""Launch a workflow script in a subprocess, serially or under ``mpirun -n N``."""

import os
import shutil
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_workflow(script, args, nproc=1, timeout=300, prepend=()):
    """Run ``workflows/<script>`` with ``args``; under mpirun via ``python -m mpi4py``.

    The child gets the start-up environment minus the PMIX_/OMPI_COMM_ variables that a
    singleton MPI_Init in this pytest process (any test importing mpi4py) adds at C level and
    that would confuse a nested mpirun; the repository root is prepended to PYTHONPATH, and
    before it the folders ``prepend`` (e.g. one holding a ``sitecustomize.py`` that injects a
    fault).
    """
    path = os.path.join(ROOT, "workflows", script)
    cmd = [sys.executable, path, *args]
    if nproc > 1:
        mpirun = shutil.which("mpirun")
        if mpirun is None:
            pytest.skip("mpirun not available")
        cmd = [mpirun, "-n", str(nproc), sys.executable, "-m", "mpi4py", path, *args]
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PMIX_", "OMPI_COMM_"))}
    env["PYTHONPATH"] = os.pathsep.join([*map(str, prepend), ROOT, env.get("PYTHONPATH", "")])
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=ROOT, env=env)
