"""The command line: usage errors are one line with exit 2; a run writes its report."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from kr210_sim import __version__
from kr210_sim.cli import main


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run", "--cycles", "0"], "must be at least 1"),
        (["run", "--cycles", "-3"], "must be at least 1"),
        (["run", "--cycles", "abc"], "expected a whole number"),
        (["run", "--slot", "10"], "must be 0 (random) or 1-9"),
        (["run", "--min-success", "1.5"], "must be in [0, 1]"),
        (["run", "--seed", "-1"], "must be >= 0"),
        (["fly"], "invalid choice"),
        ([], "required"),
    ],
)
def test_usage_errors(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


def test_unwritable_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    code = main(["run", "--cycles", "1", "--report", str(blocker / "run.json")])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("kr210_sim: error: ") and len(err.strip().splitlines()) == 1


def test_report_is_a_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--cycles", "1", "--report", str(tmp_path)]) == 2
    assert "is a folder" in capsys.readouterr().err


def test_version() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "kr210_sim", "--version"], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == f"kr210_sim {__version__}"


def test_run_writes_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    report = tmp_path / "sub" / "run.json"
    code = main(["run", "--cycles", "1", "--slot", "2", "--seed", "3", "--report", str(report)])
    assert code == 0
    out = capsys.readouterr().out
    assert "[1/1] slot 2  ok" in out and "PASS: 1/1" in out
    data = json.loads(report.read_text())
    (cycle,) = data["cycles"]
    assert cycle["success"] is True and cycle["reason"] is None and cycle["slot"] == 2
    s = data["summary"]
    assert (s["cycles"], s["successes"], s["success_rate"]) == (1, 1, 1.0)
    assert data["config"]["seed"] == 3
    assert set(data["versions"]) >= {"kr210_sim", "mujoco", "numpy", "ruckig", "python"}
    assert not list(report.parent.glob("*.tmp"))
