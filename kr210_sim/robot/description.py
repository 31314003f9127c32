"""The KR210 robot description, read from the URDF (the standard library's XML parser: the run
path loads no mesh library).

The URDF is the single source of truth for the arm's geometry and limits: kinematics, planning
and the scene builder all read their constants from :func:`load_robot`, never from literals.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from functools import lru_cache
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import SceneError
from kr210_sim.util.paths import URDF_PATH

FloatArray = npt.NDArray[np.float64]

#: Names of the six revolute arm joints, base to wrist.
ARM_JOINTS: tuple[str, ...] = tuple(f"joint_{i}" for i in range(1, 7))
#: Names of the two prismatic finger joints (right first).
FINGER_JOINTS: tuple[str, ...] = ("right_gripper_finger_joint", "left_gripper_finger_joint")
#: Links of the arm chain in order, base to gripper.
ARM_LINKS: tuple[str, ...] = (
    "base_link",
    "link_1",
    "link_2",
    "link_3",
    "link_4",
    "link_5",
    "link_6",
    "gripper_link",
)


@dataclass(frozen=True, slots=True)
class JointInfo:
    """One URDF joint as the rest of the package needs it.

    Attributes:
        name: URDF joint name.
        parent: Parent link name.
        child: Child link name.
        origin: 4x4 transform parent -> joint frame at zero position.
        axis: Unit joint axis in the joint frame (zeros for fixed joints).
        lower: Lower position limit in [rad] or [m].
        upper: Upper position limit in [rad] or [m].
        velocity: Velocity limit in [rad/s] or [m/s].
        effort: Effort limit in [N m] or [N].
    """

    name: str
    parent: str
    child: str
    origin: npt.NDArray[np.float64]
    axis: npt.NDArray[np.float64]
    lower: float
    upper: float
    velocity: float
    effort: float


@dataclass(frozen=True, slots=True)
class Geometry:
    """The KR210 constants the closed form needs, read from the URDF.

    Attributes:
        d0: Height of joint_1 above the base [m].
        a1: Forward offset of joint_2 from the joint_1 axis [m].
        h1: Height of joint_2 above joint_1 [m].
        a2: Length of link_2 (joint_2 to joint_3) [m].
        a3x: Forearm length from joint_3 to the wrist centre along x [m].
        a3z: Forearm offset from joint_3 to the wrist centre along z [m] (negative: below).
        dg: Wrist centre to gripper_link along the gripper x axis [m].
        lower: Lower joint limits [rad], shape (6,).
        upper: Upper joint limits [rad], shape (6,).
        v_max: Joint velocity limits [rad/s], shape (6,).
    """

    d0: float
    a1: float
    h1: float
    a2: float
    a3x: float
    a3z: float
    dg: float
    lower: FloatArray
    upper: FloatArray
    v_max: FloatArray
    lower_list: list[float] = field(default_factory=list, repr=False, compare=False)
    upper_list: list[float] = field(default_factory=list, repr=False, compare=False)
    inv_v2_list: list[float] = field(default_factory=list, repr=False, compare=False)

    def __post_init__(self) -> None:
        # Plain-float copies for the single-pose path (numpy scalars are slow in math code).
        object.__setattr__(self, "lower_list", self.lower.tolist())
        object.__setattr__(self, "upper_list", self.upper.tolist())
        object.__setattr__(self, "inv_v2_list", (1.0 / (self.v_max * self.v_max)).tolist())

    def __eq__(self, other: object) -> bool:
        """Equal lengths and equal limits (the arrays compared element by element)."""
        if not isinstance(other, Geometry):
            return NotImplemented
        return all(
            np.array_equal(getattr(self, f.name), getattr(other, f.name))
            for f in fields(self)
            if f.compare
        )

    __hash__ = None  # type: ignore[assignment]

    @property
    def forearm(self) -> float:
        """Distance from joint_3 to the wrist centre [m]."""
        return math.hypot(self.a3x, self.a3z)

    @property
    def forearm_angle(self) -> float:
        """Angle of the wrist centre below the forearm line, seen from joint_3 [rad]."""
        return math.atan2(-self.a3z, self.a3x)

    @property
    def reach(self) -> float:
        """Largest distance from joint_2 to the wrist centre [m]."""
        return self.a2 + self.forearm


@dataclass(frozen=True, slots=True)
class RobotDescription:
    """The figures of the KR210 read from its URDF.

    Attributes:
        urdf_path: Path of the URDF it was read from.
        joints: Every joint by name, in URDF order.
        q_lower: Lower limits of the six arm joints in [rad], shape (6,).
        q_upper: Upper limits of the six arm joints in [rad], shape (6,).
        qd_max: Velocity limits of the six arm joints in [rad/s], shape (6,).
        finger_lower: Lower finger joint limit in [m] (fully open).
        finger_upper: Upper finger joint limit in [m] (fully closed).
        finger_speed: Finger velocity limit in [m/s].
        finger_gap_at_zero: Distance between the inner finger faces at zero finger position [m].
        finger_center_x: x of the finger pads' centre in the gripper_link frame [m].
        lip_x: x of the fingertip lips' inner (palm-side) faces in the gripper_link frame [m].
        lip_depth: How far each lip stands out of its finger's inner face [m].
        geometry: The closed-form kinematics' constants, from ``joints`` and the arm's limits
            (derived, not passed: a description with changed joints has their geometry).
    """

    urdf_path: Path
    joints: dict[str, JointInfo]
    q_lower: npt.NDArray[np.float64]
    q_upper: npt.NDArray[np.float64]
    qd_max: npt.NDArray[np.float64]
    finger_lower: float
    finger_upper: float
    finger_speed: float
    finger_gap_at_zero: float
    finger_center_x: float
    lip_x: float
    lip_depth: float
    geometry: Geometry = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        geometry = _geometry(self.joints, self.q_lower, self.q_upper, self.qd_max)
        object.__setattr__(self, "geometry", geometry)

    def finger_gap(self, finger_q: float) -> float:
        """Distance between the inner finger faces [m] at finger position ``finger_q`` [m]."""
        return self.finger_gap_at_zero - 2.0 * finger_q


def _geometry(
    joints: dict[str, JointInfo], lower: FloatArray, upper: FloatArray, v_max: FloatArray
) -> Geometry:
    """The closed form's constants from the joint origins of a KR210 URDF.

    Raises:
        SceneError: When the joints are not a KR210's (rotated origins, other axes, wrist axes
            that do not meet in one point).
    """
    j = joints

    def xyz(name: str) -> FloatArray:
        origin = j[name].origin
        if not np.allclose(origin[:3, :3], np.eye(3), atol=1e-12):
            raise SceneError(f"{name} has a rotated origin; the closed form assumes rpy = 0")
        return origin[:3, 3]

    expected_axes = ((0, 0, 1), (0, 1, 0), (0, 1, 0), (1, 0, 0), (0, 1, 0), (1, 0, 0))
    for name, axis in zip(ARM_JOINTS, expected_axes, strict=True):
        if not np.allclose(j[name].axis, axis):
            raise SceneError(f"{name} axis {j[name].axis} is not {axis}: not a KR210 URDF")
    o1, o2, o3, o4, o5, o6, og = (xyz(n) for n in (*ARM_JOINTS, "gripper_joint"))
    if abs(o5[2]) > 1e-12 or abs(o6[2]) > 1e-12 or abs(og[2]) > 1e-12 or abs(o4[1]) > 1e-12:
        raise SceneError("the wrist axes do not meet in one point: no closed form")
    return Geometry(
        d0=float(o1[2]),
        a1=float(o2[0]),
        h1=float(o2[2]),
        a2=float(o3[2]),
        a3x=float(o4[0] + o5[0]),
        a3z=float(o4[2]),
        dg=float(o6[0] + og[0]),
        lower=lower.copy(),
        upper=upper.copy(),
        v_max=v_max.copy(),
    )


def _numbers(path: Path, element: ElementTree.Element | None, key: str, n: int) -> FloatArray:
    """The ``n`` numbers of attribute ``key`` of ``element`` (zeros when either is missing)."""
    text = element.get(key) if element is not None else None
    if text is None:
        return np.zeros(n)
    try:
        values = np.array([float(v) for v in text.split()], dtype=np.float64)
    except ValueError:
        values = np.zeros(0)
    if values.shape != (n,) or not np.all(np.isfinite(values)):
        raise SceneError(f"malformed URDF {path}: {key}={text!r} is not {n} numbers")
    return values


def _origin(path: Path, element: ElementTree.Element | None) -> FloatArray:
    """The 4x4 transform of an URDF ``<origin xyz rpy>`` (identity when absent)."""
    xyz, (r, p, y) = _numbers(path, element, "xyz", 3), _numbers(path, element, "rpy", 3)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    T = np.eye(4)
    T[:3, :3] = [  # Rz(y) Ry(p) Rx(r)
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    T[:3, 3] = xyz
    return T


def _limit(path: Path, element: ElementTree.Element | None, key: str) -> float:
    return float(_numbers(path, element, key, 1)[0]) if element is not None else 0.0


def _joint(path: Path, j: ElementTree.Element) -> JointInfo:
    """One ``<joint>``: its origin, axis (URDF's default x for a moving joint without one) and
    limits (0 where not given)."""
    parent, child, axis = j.find("parent"), j.find("child"), j.find("axis")
    if not j.get("name") or parent is None or child is None:
        raise SceneError(f"malformed URDF {path}: a joint lacks its name, parent or child")
    if axis is not None:
        axis_xyz = _numbers(path, axis, "xyz", 3)
    else:
        axis_xyz = np.zeros(3) if j.get("type") == "fixed" else np.array([1.0, 0.0, 0.0])
    limit = j.find("limit")
    return JointInfo(
        name=str(j.get("name")),
        parent=str(parent.get("link")),
        child=str(child.get("link")),
        origin=_origin(path, j.find("origin")),
        axis=axis_xyz,
        lower=_limit(path, limit, "lower"),
        upper=_limit(path, limit, "upper"),
        velocity=_limit(path, limit, "velocity"),
        effort=_limit(path, limit, "effort"),
    )


def _finger_boxes(
    path: Path, robot: ElementTree.Element, link_name: str
) -> list[tuple[FloatArray, FloatArray]]:
    """(origin xyz, box size) of the finger's collision boxes in [m]: the pad, then the lip."""
    boxes = []
    for link in robot.iter("link"):
        if link.get("name") != link_name:
            continue
        for collision in link.iter("collision"):
            box = collision.find("geometry/box")
            if box is not None:
                xyz = _origin(path, collision.find("origin"))[:3, 3]
                boxes.append((xyz, _numbers(path, box, "size", 3)))
    if len(boxes) != 2:
        raise SceneError(
            f"{link_name} needs two collision boxes in the URDF (pad, fingertip lip), "
            f"found {len(boxes)}"
        )
    return boxes


@lru_cache(maxsize=4)
def load_robot(urdf_path: Path | str = URDF_PATH) -> RobotDescription:
    """Read the robot description from a URDF.

    Args:
        urdf_path: Path of the KR210 URDF.

    Returns:
        The parsed description (cached per path).

    Raises:
        SceneError: When the file is missing, malformed or lacks a joint this package needs.
    """
    path = Path(urdf_path)
    if not path.is_file():
        raise SceneError(f"URDF not found: {path} (regenerate or restore assets/kr210/kr210.urdf)")
    try:
        robot = ElementTree.parse(path).getroot()
    except ElementTree.ParseError as exc:
        raise SceneError(f"malformed URDF {path}: {exc}") from exc
    if robot.tag != "robot":
        raise SceneError(f"malformed URDF {path}: the root element is <{robot.tag}>, not <robot>")
    joints: dict[str, JointInfo] = {}
    for element in robot.findall("joint"):
        joint = _joint(path, element)
        joints[joint.name] = joint
    missing = [n for n in (*ARM_JOINTS, *FINGER_JOINTS, "gripper_joint") if n not in joints]
    if missing:
        raise SceneError(f"URDF {path} lacks joints {missing}; found {sorted(joints)}")
    arm = [joints[n] for n in ARM_JOINTS]
    right = joints[FINGER_JOINTS[0]]
    (pad_xyz, pad_size), (lip_xyz, lip_size) = _finger_boxes(path, robot, right.child)
    gap0 = 2.0 * (abs(float(right.origin[1, 3])) - float(pad_size[1]) / 2.0)
    finger_x = float(right.origin[0, 3])
    return RobotDescription(
        urdf_path=path,
        joints=joints,
        q_lower=np.array([j.lower for j in arm]),
        q_upper=np.array([j.upper for j in arm]),
        qd_max=np.array([j.velocity for j in arm]),
        finger_lower=right.lower,
        finger_upper=right.upper,
        finger_speed=right.velocity,
        finger_gap_at_zero=gap0,
        finger_center_x=finger_x + float(pad_xyz[0]),
        lip_x=finger_x + float(lip_xyz[0] - lip_size[0] / 2.0),
        lip_depth=float(lip_size[1]),
    )
