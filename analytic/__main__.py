"""``python -m analytic``: see :mod:`analytic.cli`."""

import sys

from analytic.cli import main

sys.exit(main())
