"""ROS messages built and printed as genpy's."""

from __future__ import annotations

import pickle

import pytest

from kr210_sim.exercise.messages import (
    MESSAGES,
    PACKAGES,
    CalculateIK,
    Duration,
    Marker,
    Point,
    Pose,
    Quaternion,
    Time,
    TransformStamped,
)


def test_built_by_position_by_name_or_with_defaults() -> None:
    assert Point(1.0, 2.0, 3.0).y == 2.0
    assert Point(x=1.0) == Point(1.0, 0.0, 0.0)
    pose = Pose()
    assert pose.position == Point() and pose.orientation == Quaternion(0.0, 0.0, 0.0, 0.0)
    assert Pose().position is not Pose().position  # a fresh nested message each
    t = TransformStamped()
    assert t.header.frame_id == "" and t.transform.rotation.w == 0.0
    assert Marker.SPHERE == 2 and Marker().points == []
    with pytest.raises(TypeError, match=r"Invalid number of arguments"):
        Point(1.0, 2.0)
    with pytest.raises(AttributeError, match=r"w is not an attribute of Point"):
        Point(w=1.0)
    with pytest.raises(AttributeError):
        Point().w = 1.0  # type: ignore[attr-defined]


def test_printed_as_genpy_printed_them_and_pickled() -> None:
    assert str(Point(1.0, 2.5, 0.0)) == "x: 1.0\ny: 2.5\nz: 0.0"
    assert str(Pose()).startswith("position: \n  x: 0.0")
    p = Pose(Point(1.0, 2.0, 3.0), Quaternion(0.0, 0.0, 0.0, 1.0))
    assert pickle.loads(pickle.dumps(p)) == p


def test_the_service_and_the_packages() -> None:
    assert CalculateIK._request_class().poses == []
    assert CalculateIK._response_class().points == []
    assert MESSAGES["kuka_arm/CalculateIKResponse"] is CalculateIK._response_class
    assert "Pose" in PACKAGES["geometry_msgs"] and "JointState" in PACKAGES["sensor_msgs"]


def test_time_and_duration() -> None:
    t = Time(3, 500_000_000)
    assert t.to_sec() == 3.5 and Time.from_sec(3.5) == t
    assert (t - Time(1)).to_sec() == 2.5 and isinstance(t - Time(1), Duration)
    assert (t + Duration(0.5)).to_sec() == 4.0 and Time.now().to_sec() > 1e9
