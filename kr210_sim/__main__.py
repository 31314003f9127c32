"""``python -m kr210_sim``: see :mod:`kr210_sim.cli`.

The signals are held from the package's first module on (``python -m`` imports the package,
and with it mujoco, before this file runs): :mod:`kr210_sim.util.interrupts` starts the
start-up's hold as it is imported in the command's process. The call below says so here, and
holds them in any case before the CLI's imports.
"""

from __future__ import annotations

import sys

import kr210_sim.shadowed  # noqa: F401  (first: exits in one line when kr210_sim is shadowed)
from kr210_sim.util.interrupts import hold_start_up

hold_start_up()

from kr210_sim.cli import main  # noqa: E402  (after the hold)

sys.exit(main())
