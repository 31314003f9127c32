"""The README is one page that points into the site: its relative links and pictures exist, it
starts with the two commands, and it stays short. (That no page points outside the repository
is tests/test_package_layout.py's.)"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"

_LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


def test_every_relative_link_of_the_readme_and_the_site_exists() -> None:
    pages = [README, *sorted((ROOT / "docs").rglob("*.md"))]
    pages = [p for p in pages if "_build" not in p.parts]
    missing = []
    for page in pages:
        for target in _LINK.findall(page.read_text(encoding="utf-8")):
            if re.match(r"[a-z]+:", target):
                continue  # https:, mailto:
            if not (page.parent / target).resolve().exists():
                missing.append(f"{page.relative_to(ROOT)} -> {target}")
    assert not missing, missing


def test_the_readme_opens_with_the_two_commands_and_fits_on_a_page() -> None:
    lines = README.read_text(encoding="utf-8").splitlines()
    first = "\n".join(lines[:6])
    assert "make run" in first and "make test" in first
    assert len(lines) <= 120
