"""One ``CalculateIK`` request and its response, as rospy and genpy handled them.

:func:`request` builds ``CalculateIKRequest(poses=[Pose, ...])`` from our poses (gripper_link in
base_link, the frame of ``T``; the quaternion ``(x, y, z, w)``). Its ``poses`` list remembers
the pose the handler read last (:class:`PoseList`), so a handler that raised can be told to
have failed on that pose.

:func:`read_response` takes what the handler returned as rospy did (a response, a dict of its
fields, its one field's value, or a tuple or list of its fields' values; None is an error) and
reads each point's ``positions`` as genpy serialised them, with ``float()``: sympy and mpmath
numbers are converted. What is not six numbers is an unusable answer that says what it is:
a complex number (``acos`` of a value just past 1), an unevaluated sympy expression (quoted,
with its free symbols), or an object that is no number.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any, SupportsIndex

import numpy as np
import numpy.typing as npt

from kr210_sim.exercise.messages import (
    CalculateIKRequest,
    CalculateIKResponse,
    Message,
    Point,
    Pose,
    Quaternion,
)
from kr210_sim.robot.quaternions import quaternion_from_rotation

FloatArray = npt.NDArray[np.float64]

#: The arm's joints as the URDF names them (an answer's angles are named by them). Not imported
#: from :mod:`kr210_sim.robot.description`: a jail holds none of the robot's description
#: (:mod:`kr210_sim.sandbox.harness`).
ARM_JOINTS: tuple[str, ...] = tuple(f"joint_{i}" for i in range(1, 7))

#: Most positions read from one point (the guard then says "returned shape (n,)").
MAX_POSITIONS = 64
#: Longest expression quoted [characters].
QUOTED = 160


class ServiceError(Exception):
    """The handler's return value is no ``CalculateIKResponse`` rospy could send."""


class PoseList(list[Any]):
    """The request's ``poses``: a list that remembers the index read last (:attr:`last`, -1
    before any; a slice counts as its last index)."""

    last = -1

    def _saw(self, i: int) -> None:
        self.last = i

    def __getitem__(self, i: Any) -> Any:
        if isinstance(i, slice):
            span = range(*i.indices(len(self)))
            if span:
                self._saw(max(span))
        elif isinstance(i, SupportsIndex):
            k = i.__index__()
            self._saw(k if k >= 0 else len(self) + k)
        return super().__getitem__(i)

    def __iter__(self) -> Iterator[Any]:
        for i in range(len(self)):
            self._saw(i)
            yield list.__getitem__(self, i)


def pose_message(T: FloatArray) -> Any:
    """``geometry_msgs/Pose`` of the 4x4 transform ``T``."""
    x, y, z, w = quaternion_from_rotation(T[:3, :3])
    p = T[:3, 3]
    return Pose(Point(float(p[0]), float(p[1]), float(p[2])), Quaternion(x, y, z, w))


def request(poses: Sequence[FloatArray]) -> Any:
    """``CalculateIKRequest`` of the poses (4x4 each), its ``poses`` a :class:`PoseList`."""
    return CalculateIKRequest(poses=PoseList(pose_message(T) for T in poses))


class Unusable:
    """An answer that is not six numbers: converting it (``numpy.asarray``, ``float``) raises
    ``TypeError(why)``; its type's name says what it is (the guard quotes both)."""

    why = ""

    def __array__(self, *args: Any, **kwargs: Any) -> Any:
        raise TypeError(self.why)

    def __float__(self) -> float:
        raise TypeError(self.why)


def unusable(what: str, why: str) -> Unusable:
    """An :class:`Unusable` named ``what`` (its type's name) that says ``why``."""
    return type(what, (Unusable,), {"why": why})()


def _joint(j: int) -> str:
    return ARM_JOINTS[j] if j < len(ARM_JOINTS) else f"positions[{j}]"


def _quoted(value: Any) -> str:
    text = " ".join(str(value).split())
    return text if len(text) <= QUOTED else text[: QUOTED - 3] + "..."


def _number(value: Any, j: int) -> float | Unusable:
    """One position as genpy's ``float()`` read it, or why it is none."""
    if isinstance(value, complex | np.complexfloating):
        c = complex(value)
        if c.imag:
            return _complex(c, j)
        return c.real
    free = getattr(value, "free_symbols", None)
    if free:
        names = ", ".join(sorted(str(s) for s in free))
        return unusable(
            "an unevaluated sympy expression",
            f"{_joint(j)} = {_quoted(value)} has free symbols {names}: substitute numbers for "
            "them before returning it (subs or evalf(subs=...))",
        )
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError) as exc:
        try:
            c = complex(value)
        except (TypeError, ValueError, OverflowError):
            what = f"a {type(value).__name__}"
            return unusable(what, f"{_joint(j)} = {_quoted(value)} is no number ({exc})")
        if c.imag:
            return _complex(c, j)
        return c.real


def _complex(c: complex, j: int) -> Unusable:
    return unusable(
        "a complex number",
        f"{_joint(j)} = {c.real:.6g}{c.imag:+.3g}j: acos or asin of a value beyond +-1 gives a "
        "complex angle: the arm's triangle does not close (check the wrist centre and the side "
        "lengths), or a rounding just past 1 at full stretch (clip the argument to [-1, 1])",
    )


def angles(point: Any) -> list[float] | Unusable:
    """A point's ``positions`` as floats, or the unusable answer that says why not."""
    positions = getattr(point, "positions", None)
    if positions is None and not isinstance(point, Message):
        return unusable(
            f"a {type(point).__name__}",
            "a response's points must be JointTrajectoryPoint objects with the six angles "
            "in .positions",
        )
    try:
        values = list(positions) if positions is not None else []
    except TypeError:
        return unusable(
            f"a {type(positions).__name__}", "JointTrajectoryPoint.positions must be a list"
        )
    if len(values) > MAX_POSITIONS:
        return unusable(f"{len(values)} positions", "a point holds the six joint angles")
    out: list[float] = []
    for j, v in enumerate(values):
        x = _number(v, j)
        if isinstance(x, Unusable):
            return x
        out.append(x)
    return out


def response(returned: Any) -> Any:
    """``returned`` as rospy turned a handler's return value into the response.

    Raises:
        ServiceError: None, or a value that makes no ``CalculateIKResponse`` (what rospy
            refused with "service handler returned None", "handler returned invalid value" or
            "wrong number of values").
    """
    if isinstance(returned, Message) and returned._type == CalculateIKResponse._type:
        return returned
    if type(returned) is dict:
        try:
            return CalculateIKResponse(**returned)
        except (AttributeError, TypeError) as exc:
            raise ServiceError(f"the handler returned an invalid dict: {exc}") from None
    if returned is None:
        raise ServiceError("the handler returned None (rospy: service handler returned None)")
    if type(returned) not in (list, tuple):
        return CalculateIKResponse(returned)
    try:
        return CalculateIKResponse(*returned)
    except TypeError:
        raise ServiceError(
            f"the handler returned a {type(returned).__name__} of {len(returned)} values, not "
            "CalculateIKResponse(joint_trajectory_list) (rospy: handler returned wrong number "
            "of values)"
        ) from None


def points(returned: Any) -> list[Any]:
    """The points of the response to ``returned`` (see :func:`response`).

    Raises:
        ServiceError: No response, or one whose ``points`` is not a list (genpy could not
            serialise it).
    """
    got = getattr(response(returned), "points", None)
    if not isinstance(got, list | tuple):
        what = "-1" if got == -1 else f"a {type(got).__name__}"
        raise ServiceError(
            f"the handler's response holds {what} for its points, not a list of "
            "JointTrajectoryPoint (return CalculateIKResponse(joint_trajectory_list))"
        )
    return list(got)
