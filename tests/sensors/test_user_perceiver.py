"""Bring your own perception (``run --perceive --perception SPEC``): the user's function in the
real jail, a look sent whole, the example picking, and every hostile function contained and
named in one line, never a pose."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import numpy as np
import pytest

from kr210_sim.perception.camera import Intrinsics, Observation
from kr210_sim.perception.cloud import BayBox
from kr210_sim.perception.model import RecognitionModel, load_model
from kr210_sim.sandbox.jail import Jail
from kr210_sim.sandbox.perception_sandbox import open_perception
from kr210_sim.sensors.user_perceiver import UserPerception

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "perception_simple.py"
CLUTTERED = REPO / "scenes" / "cells" / "cluttered.toml"

HOSTILE = """
import os, time
import numpy as np

def echo(look):  # what it was given, read back: the look crossed whole
    rgb, depth = look["rgb"], look["depth"]
    return [{{"label": look["pick"],
             "position": [float(rgb.sum()), float(depth.sum()), float(rgb.shape[1])],
             "axis": look["T_base_camera"][:3, 2], "confidence": float(look["K"][0, 0] / 50)}}]

def reads(look):
    return [{{"label": open({secret!r}).read(), "position": [0, 0, 0]}}]

def writes(look):  # its own file, to change what it is scored as
    with open(__file__, "a") as f:
        f.write("# CHANGED".lower())
    return []

def grader(look):
    from kr210_sim.robot.kinematics import nearest
    return []

def raises(look):
    raise ValueError("no blue here")

def sleeps(look):
    time.sleep(60)

def nan(look):
    return [{{"label": look["pick"], "position": [np.nan, 0.0, 1.0]}}]

def many(look):
    return [{{"label": "target", "position": [0.0, 0.0, 0.0]}}] * 10**7

def nothing(look):
    return None

def exits(look):
    os._exit(3)

def hogs(look):
    return np.ones(10**10)
"""


@pytest.fixture(scope="module")
def model() -> RecognitionModel:
    return load_model()


def _look(sensor: str = "shelf_rgbd") -> Observation:
    intr = Intrinsics.from_fovy(64, 48, 52.0)
    rgb = (np.arange(64 * 48 * 3) % 251).astype(np.uint8).reshape(48, 64, 3)
    depth = np.full((48, 64), 1.5, dtype=np.float32)
    return Observation(sensor, rgb, depth, intr, np.eye(4), 0.25)


BAY = BayBox((2.69, 0.0, 1.875), 0.0, (0.2, 0.4, 0.3))


@pytest.fixture
def hostile(tmp_path: Path) -> Path:
    secret = tmp_path / "secret.txt"
    secret.write_text("the answers")
    user = tmp_path / "hostile.py"
    user.write_text(HOSTILE.format(secret=str(secret)))
    return user


def _perceive(user: Path, name: str, model: RecognitionModel, timeout: float = 5.0):  # type: ignore[no-untyped-def]
    box = open_perception(f"{user}:{name}", timeout, confinement=Jail())
    try:
        user = UserPerception(box, ("target", "red_can"), model.kinds)
        return user([_look()], "target", BAY, model), box
    finally:
        box.close()


def test_a_look_crosses_into_the_jail_whole(
    hostile: Path, model: RecognitionModel, jail_ok: None
) -> None:
    obs = _look()
    p, box = _perceive(hostile, "echo", model)
    assert box.confinement.name == "bwrap"
    assert p.seen and p.reason == "" and p.confident
    assert p.target is not None and p.target.pose is not None
    sums = (float(obs.rgb.astype(np.int64).sum()), float(obs.depth.sum()), 64.0)
    assert tuple(p.target.pose.position) == pytest.approx(sums)
    assert p.target.confidence == pytest.approx(obs.intrinsics.fx / 50)
    assert tuple(p.target.pose.axis) == (0.0, 0.0, 1.0)


@pytest.mark.parametrize(
    ("name", "reason"),
    [
        ("reads", "hostile.py:reads raised FileNotFoundError: [Errno 2] No such file"),
        ("writes", "hostile.py:writes raised OSError: [Errno 30] Read-only file system"),
        ("grader", "hostile.py:grader raised ModuleNotFoundError: No module named "),
        ("raises", "hostile.py:raises raised ValueError: no blue here (hostile.py line 24)"),
        ("sleeps", "hostile.py:sleeps: no answer within 2 s"),
        ("nan", "hostile.py:nan: entry 0's 'position' holds NaN or infinity: [nan, 0.0, 1.0]"),
        ("many", "hostile.py:many: returned 10,000,000 entries (at most 64)"),
        ("nothing", "hostile.py:nothing: returned None (an empty list says nothing was seen)"),
        ("exits", "hostile.py:exits: the perception process exited with code 3 during a call"),
        ("hogs", "hostile.py:hogs: ran out of memory during a call (limit 2048 MB)"),
    ],
)
def test_a_hostile_function_is_contained_and_named(
    hostile: Path, model: RecognitionModel, name: str, reason: str, jail_ok: None
) -> None:
    p, box = _perceive(hostile, name, model, timeout=2.0)
    assert not p.seen and p.target is None and not p.confident
    assert p.reason.startswith(reason), p.reason
    assert "\n" not in p.reason and "Traceback" not in p.reason
    assert "the answers" not in p.reason  # the file outside was not there to read
    assert "# changed" not in hostile.read_text()
    assert box._proc is None  # nothing left running


def test_an_empty_answer_is_not_seen_with_what_was_returned(
    tmp_path: Path, model: RecognitionModel, jail_ok: None
) -> None:
    user = tmp_path / "other.py"
    user.write_text("def f(look):\n    return [{'label': 'red_can', 'position': [1, 2, 3]}]\n")
    p, _ = _perceive(user, "f", model)
    assert not p.seen
    assert p.reason == "not seen (other.py:f returned shelf_rgbd: red_can)"


def _run(spec: str, tmp_path: Path, cycles: int) -> dict:  # type: ignore[type-arg]
    from kr210_sim.api import run

    report = tmp_path / "report.json"
    run(cycles, seed=0, cell=CLUTTERED, report=report, perceive=True, perception=spec)
    data: dict = json.loads(report.read_text())  # type: ignore[type-arg]
    return data


@pytest.mark.chaotic
def test_the_example_picks_from_what_it_saw_in_the_jail(tmp_path: Path, jail_ok: None) -> None:
    data = _run(f"{EXAMPLE}:perceive", tmp_path, 2)
    assert data["summary"]["successes"] == 2
    function = data["summary"]["perception"]["function"]
    assert function["confinement"] == "bwrap" and function["looks"] == 2
    assert function["faults"] == []
    again = _run(f"{EXAMPLE}:perceive", tmp_path, 1)  # the same process serves the next run
    assert again["summary"]["perception"]["function"]["looks"] == 1  # its looks, not 3
    for cycle in data["cycles"]:
        p = cycle["perception"]
        assert p["seen"] and p["right_object"] and p["label_seen"] == p["label"]
        assert p["position_error_mm"] < 10.0 and p["axis_error_deg"] < 5.0
        assert p["cpu_time_ms"] > 0.0


@pytest.mark.chaotic
def test_a_low_confidence_asks_the_wrist_camera_and_a_fault_is_the_cycles_reason(
    tmp_path: Path, jail_ok: None
) -> None:
    user = tmp_path / "unsure.py"
    user.write_text(
        EXAMPLE.read_text()
        + textwrap.dedent(
            """

            def unsure(look):  # the fixed sensor's guess is not trusted
                out = perceive(look)
                for entry in out:
                    entry["confidence"] = 0.3 if look["sensor"] != "gripper" else 0.95
                return out

            def broken(look):
                raise RuntimeError("lens cap on")
            """
        )
    )
    data = _run(f"{user}:unsure", tmp_path, 1)
    p = data["cycles"][0]["perception"]
    assert data["summary"]["successes"] == 1
    assert p["looks"] == 2 and p["confidence"] == 0.95 and p["right_object"]
    data = _run(f"{user}:broken", tmp_path, 1)
    cycle = data["cycles"][0]
    assert cycle["reason"] == "not_seen" and not cycle["success"]
    assert cycle["perception"]["reason"].startswith(
        "unsure.py:broken raised RuntimeError: lens cap on (unsure.py line"
    )
