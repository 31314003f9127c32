"""A folder named ``kr210_sim`` in the working folder shadows the package: one line, exit 2."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from kr210_sim.shadowed import PACKAGE_DIR, shadow_message, shadowing_folder


def _imported_as_kr210_sim(cwd: Path) -> str:
    """What ``import kr210_sim`` finds from ``cwd``: its ``__file__`` (None for a namespace)."""
    code = "import kr210_sim; print(getattr(kr210_sim, '__file__', None))"
    return subprocess.run(
        [sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True, check=True
    ).stdout.strip()


def _shadow(tmp_path: Path, init: str | None) -> Path:
    """``tmp_path`` holding ``kr210_sim/`` as a clone's top level (no ``__init__.py``) or as
    another package (``init``); skipped where that does not shadow this install."""
    folder = tmp_path / "kr210_sim"
    folder.mkdir()
    (folder / "README.md").write_text("a clone\n")
    if init is not None:
        (folder / "__init__.py").write_text(init)
    found = _imported_as_kr210_sim(tmp_path)
    if found != "None" and Path(found).resolve().parent == PACKAGE_DIR:
        # A wheel's regular package wins over a namespace folder; an editable install's finder
        # comes after the working folder, so there the folder is what `import kr210_sim` gets.
        pytest.skip("a kr210_sim/ folder does not shadow this install of the package")
    return folder


@pytest.mark.parametrize(
    ("init", "what"),
    [(None, "a folder without __init__.py"), ("VERSION = '0.0.1'\n", "another package")],
)
@pytest.mark.parametrize("entry", ["python -m", "console script"])
def test_a_shadowing_folder_is_one_line_and_exit_2(
    tmp_path: Path, init: str | None, what: str, entry: str
) -> None:
    folder = _shadow(tmp_path, init)
    if entry == "python -m":
        argv, env = [sys.executable, "-m", "kr210_sim", "run", "--cycles", "1"], dict(os.environ)
    else:
        script = Path(sys.executable).parent / "kr210-sim"
        if not script.is_file():
            pytest.skip("no kr210-sim console script beside this Python")
        # The console script's sys.path starts at its own folder, not the working one: the
        # folder shadows it where PYTHONPATH names the working folder.
        argv, env = [str(script), "--version"], {**os.environ, "PYTHONPATH": "."}
    proc = subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.splitlines() == [shadow_message(folder.resolve())]
    assert f"{folder.resolve()} ({what}) is imported as kr210_sim instead of" in proc.stderr
    assert "run from another folder" in proc.stderr
    assert ("cd into" in proc.stderr) is (init is None)


def test_the_package_itself_is_not_shadowed(tmp_path: Path) -> None:
    assert shadowing_folder() is None
    proc = subprocess.run(
        [sys.executable, "-m", "kr210_sim", "--version"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0 and proc.stdout.startswith("kr210_sim ")
