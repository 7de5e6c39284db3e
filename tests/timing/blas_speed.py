"""OpenBLAS against Debian's reference BLAS/LAPACK, side by side in one run (CPU seconds).

    ./run python tests/timing/blas_speed.py [--sweep]

Each case runs in a child process twice, once with the libraries Debian's alternatives choose
(OpenBLAS, installed by ./run) and once with ``LD_LIBRARY_PATH`` pointing at the reference
BLAS/LAPACK (``libblas3``, ``liblapack3``), alternating, and the children's CPU time (user +
system, ``resource.getrusage``: less sensitive to a shared machine's load than wall time) is
compared (a child's start, about 0.3 s, included). Cases: a dense symmetric ``eigh``
(n = 1000, what the 1D sweep's condensed form does per k at larger k) and a dense complex LU
(n = 1500), each five times, and with ``--sweep`` the default FE-first sweep on one rank
(``sweep_k.py --check-exact no``). Prints one line per case: reference s, OpenBLAS s, ratio.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
REFERENCE = "/usr/lib/x86_64-linux-gnu/blas:/usr/lib/x86_64-linux-gnu/lapack"
KERNELS = {
    "eigh n=1000, 5 times": "import numpy as np, scipy.linalg as s; a = np.random.default_rng(1)"
                            ".random((1000, 1000)); [s.eigh(a + a.T) for _ in range(5)]",
    "complex LU n=1500, 5 times": "import numpy as np, scipy.linalg as s; r = np.random."
                                  "default_rng(1); a = r.random((1500, 1500)) + 1j * r.random("
                                  "(1500, 1500)); [s.lu_factor(a) for _ in range(5)]",
}


def cpu_seconds(cmd: list[str], reference: bool) -> float:
    """CPU seconds of ``cmd`` run as a child (reference BLAS or the default)."""
    env = dict(os.environ)
    if reference:
        env["LD_LIBRARY_PATH"] = REFERENCE
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sweep", action="store_true", help="also the default sweep (one rank)")
    args = ap.parse_args()
    if not os.path.isdir(REFERENCE.split(":")[0]):
        print("the reference BLAS (libblas3) is not installed: nothing to compare", flush=True)
        return 2
    cases = {name: [sys.executable, "-c", code] for name, code in KERNELS.items()}
    if args.sweep:
        out = tempfile.mkdtemp(prefix="blas_speed_")
        cases["default sweep, 1 rank"] = [
            sys.executable, os.path.join(ROOT, "workflows", "sweep_k.py"), "--check-exact", "no",
            "--no-plot", "--quiet", "--out", os.path.join(out, "s")]
    for name, cmd in cases.items():
        t = {}
        for reference in (True, False):  # alternating: the same machine state for both
            if "--out" in cmd:
                cmd = cmd[:-1] + [cmd[-1] + ("_ref" if reference else "_ob")]
            t[reference] = cpu_seconds(cmd, reference)
        print(f"{name}: reference {t[True]:.2f} s, OpenBLAS {t[False]:.2f} s, "
              f"ratio {t[True] / t[False]:.1f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
