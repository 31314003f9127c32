"""Text for a terminal (util/console.py): :func:`escape` makes any text inert, and the commands
whose lines quote a user's IK (``run --ik``, ``ik-check --ik``, an error at its import) print
what a hostile IK raised as visible escapes, never as bytes a terminal acts on (REDTEAM-4
finding 6)."""

from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from chromium import free_port

from kr210_sim.util.console import EscapingStream, escape

ROOT = Path(__file__).resolve().parents[2]


#: What a hostile student's exception says: cursor up, erase the line, a carriage return and a
#: fake ``pass`` row, the window title (OSC 0), the clipboard (OSC 52), a bell, a C1 CSI that
#: clears the screen, and a bidi override.
HOSTILE = (
    "\x1b[1A\x1b[2K\r  1  honest   pass  85/85\x1b]0;owned\x07"
    "\x1b]52;c;ZWNobyBvd25lZA==\x07\x9b2J\u202egnp.exe\x7f"
)
#: Bytes (in UTF-8) no output may carry: ESC, BEL, CR, C1 CSI (U+009B), RLO (U+202E), DEL.
RAW = (b"\x1b", b"\x07", b"\r", b"\xc2\x9b", b"\xe2\x80\xae", b"\x7f")


def raw_controls(data: bytes) -> list[bytes]:
    """Which of :data:`RAW` ``data`` holds."""
    return [b for b in RAW if b in data]


def test_escape_makes_every_control_character_visible() -> None:
    shown = escape(HOSTILE)
    assert shown.isprintable() and raw_controls(shown.encode()) == []
    assert shown.startswith("\\x1b[1A\\x1b[2K\\r  1  honest")
    assert "\\x1b]52;c;ZWNobyBvd25lZA==\\x07" in shown and "\\x9b2J\\u202egnp" in shown
    assert escape("a\nb\tc") == "a\\nb\\tc"  # one line
    assert escape("a\nb\tc\x1b", lines=True) == "a\nb\tc\\x1b"  # its lines kept, not the rest
    assert escape("caf\u00e9 \u2713 C:\\x1b") == "caf\u00e9 \u2713 C:\\x1b"  # printable: as is
    assert escape(os.fsdecode(b"bad\xffname")) == "bad\\xffname"
    assert escape("\ud800") == "\\ud800"


def test_escape_of_any_text_is_printable_and_escaping_it_again_changes_nothing() -> None:
    rng = np.random.default_rng(0)
    for _ in range(2000):  # code points of every plane, controls and surrogates included
        text = "".join(chr(int(c)) for c in rng.integers(0, 0x110000, size=8))
        text += "".join(chr(int(c)) for c in rng.integers(0, 0x100, size=8))
        one, many = escape(text), escape(text, lines=True)
        assert one.isprintable() and escape(one) == one
        assert all(c.isprintable() or c in "\n\t" for c in many)
        one.encode("utf-8")  # strict: no surrogate left


def test_an_escaping_stream_writes_escaped_text_and_keeps_lines() -> None:
    buffer = io.StringIO()
    stream = EscapingStream(buffer)
    assert stream.write(f"cycle 1: {HOSTILE}\nnext\n") == len(HOSTILE) + 15
    assert buffer.getvalue() == f"cycle 1: {escape(HOSTILE)}\nnext\n"


# -- the commands, with a hostile IK in the jail -----------------------------------------------
def _command(args: list[str], cwd: Path) -> subprocess.CompletedProcess[bytes]:
    env = dict(os.environ, PYTHONPATH=str(ROOT), KR210_JAIL="1")
    return subprocess.run(
        [sys.executable, "-m", "kr210_sim", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        timeout=600,
    )


@pytest.mark.slow
@pytest.mark.usefixtures("jail_ok")
@pytest.mark.parametrize("command", ["run", "ik-check", "import", "view", "run -v"])
def test_a_hostile_ik_s_text_reaches_no_terminal_raw(tmp_path: Path, command: str) -> None:
    """``run --ik``, ``ik-check --ik`` and ``view --ik`` quote what the IK raised; an IK whose
    import raises is a one-line error. All of them printed the ESC and BEL bytes as they
    were."""
    body = f"def solve(T, q):\n    raise ValueError({HOSTILE!r})\n"
    if command == "import":
        body = f"raise ValueError({HOSTILE!r})\n" + body
    (tmp_path / "hostile.py").write_text(body)
    ik = ["--ik", "hostile.py:solve", "--ik-timeout", "2"]
    report = ["--report", str(tmp_path / "report.json")]
    if command == "ik-check":
        args = ["ik-check", *ik, "--cases", "2", *report]
    elif command == "view":
        web = ["--web", "--port", str(free_port()), "--speed", "50", "--exit-when-done"]
        args = ["view", *web, *ik, "--cycles", "1", *report]
    else:
        args = [*command.split()[1:], "run", *ik, "--cycles", "1", *report]
    done = _command(args, tmp_path)
    assert done.returncode in (1, 2), done.stderr
    out = done.stdout + done.stderr
    assert b"Traceback" not in out
    assert raw_controls(out) == []
    assert b"\\x1b]52;c;ZWNobyBvd25lZA==\\x07" in out  # said, as visible escapes
    if command == "run -v":  # the runner's log line of the failed cycle quotes it too
        assert b"INFO kr210_sim.sim.runner: cycle 1: " in done.stderr
        assert b"\\x1b]52;c;ZWNobyBvd25lZA==\\x07" in done.stderr
