"""A ``python -m kr210_sim`` start-up held at one import, for the tests of signals that arrive
during it (tests/util/test_interrupts_signals.py, tests/grading/test_grade.py)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

HOLD_AN_IMPORT = """
    import os, sys, time

    class _Hold:
        def find_spec(self, name, path=None, target=None):
            if name == os.environ["KR210_TEST_HOLD"]:
                sys.meta_path.remove(self)
                mark = os.environ["KR210_TEST_MARK"]
                open(mark, "w").close()
                deadline = time.monotonic() + 120
                while not os.path.exists(mark + ".go") and time.monotonic() < deadline:
                    time.sleep(0.005)
            return None

    sys.meta_path.insert(0, _Hold())
"""


def held_at(module: str, args: list[str], tmp_path: Path) -> tuple[subprocess.Popen[str], Path]:
    """Start ``python -m kr210_sim ARGS`` and wait until its start-up imports ``module``."""
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(textwrap.dedent(HOLD_AN_IMPORT))
    mark = tmp_path / "at-the-import"
    env = {**os.environ, "PYTHONPATH": str(site), "KR210_TEST_HOLD": module}
    env["KR210_TEST_MARK"] = str(mark)
    proc = subprocess.Popen(
        [sys.executable, "-m", "kr210_sim", *args],
        cwd=tmp_path,
        env=env,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while not mark.exists():
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.005)
    return proc, mark
