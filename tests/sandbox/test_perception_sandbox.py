"""The sandbox of ``--perception SPEC`` and the command line's one-line errors about it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.errors import ConfigError, PerceptionSpecError
from kr210_sim.sandbox.jail import Jail
from kr210_sim.sandbox.perception_sandbox import open_perception
from kr210_sim.sandbox.user_perception import read_answer

REPO = Path(__file__).resolve().parents[2]
CLUTTERED = REPO / "scenes" / "cells" / "cluttered.toml"


def test_a_full_size_look_crosses_and_a_fresh_process_follows_a_timeout(
    tmp_path: Path, jail_ok: None
) -> None:
    user = tmp_path / "sizes.py"
    user.write_text(
        "import time\n"
        "def f(look):\n"
        "    if look['pick'] == 'slow':\n"
        "        time.sleep(30)\n"
        "    d = look['depth']\n"
        "    where = [d.mean(), d.max(), d.dtype.itemsize]\n"
        "    return [{'label': str(look['rgb'].shape), 'position': where}]\n"
    )
    box = open_perception(f"{user}:f", 2.0, confinement=Jail())
    try:
        rgb = np.zeros((480, 640, 3), np.uint8)
        depth = np.random.default_rng(0).uniform(0.5, 3.0, (480, 640)).astype(np.float32)
        got = read_answer(box.look({"pick": "target"}, {"rgb": rgb, "depth": depth}))
        assert got[0].label == "(480, 640, 3)"
        assert got[0].position == pytest.approx((depth.mean(), depth.max(), 4), rel=1e-5)
        from kr210_sim.sandbox.ik_sandbox import IkTimeout

        with pytest.raises(IkTimeout, match="no answer within 2 s"):
            box.look({"pick": "slow"}, {"rgb": rgb, "depth": depth})
        assert box.faults == ["no answer within 2 s"]
        got = read_answer(box.look({"pick": "target"}, {"rgb": rgb, "depth": depth}))
        assert got[0].label == "(480, 640, 3)" and box.starts == 2
        summary = box.summary()
        assert summary["looks"] == 3 and summary["confinement"] == "bwrap"
        with pytest.raises(ConfigError, match="a look of over"):
            box.look({}, {"rgb": np.zeros((5000, 5000, 3), np.uint8)})
    finally:
        box.close()


def test_a_bad_spec_fails_at_start_in_one_line(tmp_path: Path, jail_ok: None) -> None:
    user = tmp_path / "bad.py"
    user.write_text("import numpy\nraise SystemExit('no')\n")
    with pytest.raises(PerceptionSpecError) as caught:
        open_perception(f"{user}:f", confinement=Jail())
    assert str(caught.value).startswith(f"--perception '{user}:f': ")
    with pytest.raises(PerceptionSpecError, match="no such file"):
        open_perception(f"{tmp_path}/none.py:f")


@pytest.mark.parametrize(
    ("argv", "error"),
    [
        (
            ["--perception", "x.py:f"],
            "--perception needs --perceive (it replaces our perception)",
        ),
        (
            ["--perception-timeout", "2"],
            "--perception-timeout needs --perception SPEC",
        ),
        (
            ["--perceive", "--perception", "missing.py:perceive"],
            "--perception 'missing.py:perceive': no such file missing.py",
        ),
        (
            ["--perceive", "--perception", "{tmp}/p.py:nope"],
            "--perception '{tmp}/p.py:nope': {tmp}/p.py has no function 'nope'",
        ),
        (
            ["--perceive", "--perception", "{tmp}/p.py"],
            "--perception '{tmp}/p.py': expected package.module:function or "
            "path/to/file.py:function",
        ),
    ],
)
def test_the_command_lines_errors_are_one_line(
    argv: list[str], error: str, tmp_path: Path, capsys: pytest.CaptureFixture, jail_ok: None
) -> None:
    from kr210_sim.cli import main

    (tmp_path / "p.py").write_text("def perceive(look):\n    return []\n")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    report = tmp_path / "r.json"
    assert main(["run", "--cycles", "1", *argv, "--report", str(report)]) == 2
    err = capsys.readouterr().err
    assert err == f"kr210_sim: error: {error.replace('{tmp}', str(tmp_path))}\n"
    assert not report.exists()


def test_the_command_runs_a_users_perception_and_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture, jail_ok: None
) -> None:
    from kr210_sim.cli import main

    user = tmp_path / "blind.py"
    user.write_text("def perceive(look):\n    return []\n")
    report = tmp_path / "r.json"
    argv = ["run", "--cycles", "1", "--perceive", "--cell", str(CLUTTERED)]
    argv += ["--perception", f"{user}:perceive", "--report", str(report)]
    assert main(argv) == 1
    out = capsys.readouterr().out
    assert f"perception {user}:perceive: 2 looks in bwrap, 0 faults" in out
    cycle = json.loads(report.read_text())["cycles"][0]
    assert cycle["reason"] == "not_seen"
    assert cycle["perception"]["reason"].startswith("not seen (blind.py:perceive returned")


def test_no_jail_runs_it_unjailed_and_says_what_is_then_unprotected(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    from kr210_sim.cli import main

    user = tmp_path / "blind.py"
    user.write_text("def perceive(look):\n    return []\n")
    argv = ["run", "--cycles", "1", "--perceive", "--perception", f"{user}:perceive", "--no-jail"]
    assert main([*argv, "--slot", "8", "--report", str(tmp_path / "r.json")]) == 1
    got = capsys.readouterr()
    assert "--no-jail: your perception function's code runs as you" in got.err
    assert f"perception {user}:perceive: 2 looks in none, 0 faults" in got.out
