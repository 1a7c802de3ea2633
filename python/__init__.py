"""D-Snake registration (Levi & Gotsman) from Python: docs/python.md."""
import os as _os

# OpenMP's idle threads sleep rather than spin, as the dsnake executable sets for itself
# (experiments/cli/main.cpp): spinning threads on a machine with other work made a run up to twice
# as long. libgomp reads this when it loads, so it is set before the extension loads it; a
# setting of the user's own is kept.
if "OMP_WAIT_POLICY" not in _os.environ and "GOMP_SPINCOUNT" not in _os.environ:
    _os.environ["OMP_WAIT_POLICY"] = "PASSIVE"

from ._dsnake import *  # noqa: E402,F401,F403
from ._dsnake import __doc__  # noqa: E402,F401
