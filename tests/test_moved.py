"""The module paths that moved in 0.2.0 (kr210_sim._moved): old paths give the new modules, with a
DeprecationWarning that names the new path, for one release."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

from kr210_sim import _moved


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("kr210_sim.robot.jail", "kr210_sim.sandbox.jail"),
        ("kr210_sim.robot.user_ik", "kr210_sim.sandbox.user_ik"),
        ("kr210_sim.robot.ros", "kr210_sim.exercise"),
        ("kr210_sim.robot.ros.form", "kr210_sim.exercise.form"),
        ("kr210_sim.eval.grade", "kr210_sim.grading.grade"),
        ("kr210_sim.eval.ikcheck", "kr210_sim.grading.ikcheck"),
    ],
)
def test_an_old_module_path_is_the_new_module_with_a_warning(old: str, new: str) -> None:
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=rf"{old} moved to {new} in 0\.2\.0.*0\.3\.0"):
        module = importlib.import_module(old)
    assert module is importlib.import_module(new)  # one module object, not a copy


def test_the_names_the_old_packages_exported_still_resolve_with_a_warning() -> None:
    from kr210_sim.grading.grade import GradeSettings
    from kr210_sim.sandbox.user_ik import UserIk

    with pytest.warns(DeprecationWarning, match="kr210_sim.robot.UserIk moved"):
        from kr210_sim.robot import UserIk as old_user_ik
    with pytest.warns(DeprecationWarning, match="kr210_sim.eval.GradeSettings moved"):
        from kr210_sim.eval import GradeSettings as old_settings
    assert (old_user_ik, old_settings) == (UserIk, GradeSettings)
    import kr210_sim.robot

    with pytest.raises(AttributeError, match="has no attribute 'nothing_here'"):
        getattr(kr210_sim.robot, "nothing_here")  # noqa: B009


def test_paths_that_did_not_move_are_left_alone() -> None:
    assert _moved.new_name("kr210_sim.robot.kinematics") is None
    assert _moved.new_name("kr210_sim.robot.rosette") is None  # a prefix of a word is no match
    assert _moved.new_name("kr210_sim.eval.evaluate") is None
    assert _moved.new_name("kr210_sim.robot.ros.shims") == "kr210_sim.exercise.shims"


def test_an_old_import_in_a_fresh_process_warns_from_the_importers_line() -> None:
    """The warning points at the line that imported the old path (a user's script), not at
    importlib's frames."""
    code = "import warnings\nwarnings.simplefilter('always')\nimport kr210_sim.robot.jail\n"
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    assert "<string>:3: DeprecationWarning: kr210_sim.robot.jail moved to" in done.stderr
