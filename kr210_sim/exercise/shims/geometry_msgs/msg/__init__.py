"""geometry_msgs.msg: its messages (:mod:`kr210_sim.exercise.messages`)."""

from kr210_sim.exercise.messages import (
    Point,
    Point32,
    PointStamped,
    Pose,
    PoseArray,
    PoseStamped,
    Quaternion,
    Transform,
    TransformStamped,
    Twist,
    Vector3,
)

__all__ = [
    "Point",
    "Point32",
    "PointStamped",
    "Pose",
    "PoseArray",
    "PoseStamped",
    "Quaternion",
    "Transform",
    "TransformStamped",
    "Twist",
    "Vector3",
]
