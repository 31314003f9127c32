"""The tutorials run: every fenced ``bash`` block of ``docs/tutorials/*.md`` is executed, in
order, in a fresh folder holding a copy of ``examples/``, with the test's Python first on
``PATH`` (so ``python`` and ``kr210-sim`` are this checkout's).

A block runs as one ``bash -e`` script. It must exit with 0, unless an HTML comment
``<!-- exits: N -->`` stands on the line before its fence (invisible on the page), as for a
command the tutorial shows failing on purpose. The blocks of one tutorial share the folder,
so a later block sees the files an earlier one wrote. A ``text`` block after a ``bash`` block
shows its output: its lines that hold no timings (the verdicts ``PASS:``, ``FAIL:``,
``cell ...:`` and the instructor's gradebook rows) must be printed by it word for word.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TUTORIALS = sorted((ROOT / "docs" / "tutorials").glob("*.md"))

_FENCE = re.compile(r"^```(\S*)\s*$")
_VERDICTS = ("PASS:", "FAIL:", "cell ", "student,", "alice,")
_EXITS = re.compile(r"^<!--\s*exits:\s*(\d+)\s*-->\s*$")


@dataclass(frozen=True)
class Block:
    """One fenced code block: its language, text, first line (1-based) and expected exit."""

    language: str
    text: str
    line: int
    exit_code: int


def blocks(markdown: str) -> list[Block]:
    """The fenced code blocks of a Markdown text, in order (no nesting: MyST has none here)."""
    found: list[Block] = []
    lines = markdown.splitlines()
    i = 0
    while i < len(lines):
        match = _FENCE.match(lines[i])
        if not match:
            i += 1
            continue
        expected = 0
        if i > 0 and (exits := _EXITS.match(lines[i - 1])):
            expected = int(exits.group(1))
        start = i
        i += 1
        body: list[str] = []
        while i < len(lines) and not lines[i].startswith("```"):
            body.append(lines[i])
            i += 1
        if i == len(lines):
            raise ValueError(f"line {start + 1}: a fence that is never closed")
        found.append(Block(match.group(1), "\n".join(body) + "\n", start + 1, expected))
        i += 1
    return found


def test_blocks_are_found_with_their_expected_exit() -> None:
    text = "a\n```bash\necho 1\n```\n<!-- exits: 3 -->\n```bash\nexit 3\n```\n```text\nout\n```\n"
    found = blocks(text)
    assert [(b.language, b.exit_code, b.line) for b in found] == [
        ("bash", 0, 2),
        ("bash", 3, 6),
        ("text", 0, 9),
    ]
    with pytest.raises(ValueError, match="never closed"):
        blocks("```bash\necho\n")


def test_every_tutorial_has_commands_and_only_known_languages() -> None:
    assert {p.stem for p in TUTORIALS} == {"student", "instructor", "engineer"}
    for path in TUTORIALS:
        found = blocks(path.read_text(encoding="utf-8"))
        assert any(b.language == "bash" for b in found), path.name
        assert {b.language for b in found} <= {"bash", "text"}, path.name


@pytest.mark.parametrize("path", TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_tutorial_runs(path: Path, tmp_path: Path) -> None:
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env.pop("PYTHONPATH", None)
    env.setdefault("MUJOCO_GL", "egl")
    output = ""
    for block in blocks(path.read_text(encoding="utf-8")):
        if block.language == "text":
            for line in block.text.splitlines():
                if line.startswith(_VERDICTS):
                    assert line in output, f"{path.name}:{block.line}: not printed: {line!r}"
            continue
        done = subprocess.run(
            ["bash", "-e", "-c", block.text],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )
        output = done.stdout + done.stderr
        assert done.returncode == block.exit_code, (
            f"{path.name}:{block.line}: exit {done.returncode}, expected {block.exit_code}\n"
            f"{block.text}\n--- stdout\n{done.stdout[-3000:]}\n--- stderr\n{done.stderr[-3000:]}"
        )
    assert list(tmp_path.glob("reports/*.json")), "the tutorial wrote no report"
