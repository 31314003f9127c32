"""tf's and tf2_ros's frame classes without a tf tree."""

from __future__ import annotations

import pytest

from kr210_sim.exercise import frames
from kr210_sim.exercise.messages import TransformStamped


def test_only_transforms_set_here_are_found() -> None:
    listener = frames.TransformListener()
    with pytest.raises(frames.LookupException, match=r'"base_link" passed to lookupTransform'):
        listener.lookupTransform("base_link", "gripper_link", 0)
    t = TransformStamped()
    t.header.frame_id, t.child_frame_id = "/base_link", "link_1"
    t.transform.translation.z, t.transform.rotation.w = 0.33, 1.0
    listener.setTransform(t)
    assert listener.lookupTransform("base_link", "link_1", 0) == (
        (0.0, 0.0, 0.33),
        (0.0, 0.0, 0.0, 1.0),
    )
    assert listener.canTransform("base_link", "link_1", 0) and listener.getFrameStrings() == [
        "base_link",
        "link_1",
    ]
    buffer = frames.Buffer()
    buffer.set_transform(t)
    assert buffer.lookup_transform("base_link", "link_1", 0) is t
    with pytest.raises(frames.TransformException):
        buffer.lookup_transform("world", "link_1", 0)
    frames.TransformBroadcaster().sendTransform(t)
