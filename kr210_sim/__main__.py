"""``python -m kr210_sim``: see :mod:`kr210_sim.cli`."""

from __future__ import annotations

import sys

from kr210_sim.cli import main

sys.exit(main())
