"""ROS messages as IK servers build and read them: genpy's message classes, without ROS.

A message class lists its fields in ``__slots__`` and their ROS types in ``_slot_types``, as
genpy generated them. It is built like genpy's: ``Pose()`` (every field its default: 0 for
numbers, "" for strings, an empty list for arrays, a fresh message for a nested one),
``Point(1.0, 2.0, 3.0)`` (all fields by position) or ``Point(x=1.0)`` (some by name, the rest
their defaults). Messages compare by value and print as genpy printed them (YAML-like).

The classes the ROS packages' shims export (``geometry_msgs.msg.Pose``, ``kuka_arm.srv.
CalculateIKRequest``, ...) are defined here, and so is the service ``CalculateIK`` of the
exercise (``geometry_msgs/Pose[] poses --- trajectory_msgs/JointTrajectoryPoint[] points``).
"""

from __future__ import annotations

from typing import Any, ClassVar

#: Default values of the ROS built-in types.
_NUMBERS = {"float32", "float64"}
_INTEGERS = {"int8", "int16", "int32", "int64", "uint8", "uint16", "uint32", "uint64", "byte"}


class Time:
    """``rospy.Time`` / ``genpy.Time``: seconds and nanoseconds.

    Args:
        secs: Whole seconds.
        nsecs: Nanoseconds.
    """

    __slots__ = ("nsecs", "secs")

    def __init__(self, secs: float = 0, nsecs: int = 0) -> None:
        whole = int(secs)
        self.secs = whole
        self.nsecs = int(nsecs) + round((float(secs) - whole) * 1e9)

    @classmethod
    def from_sec(cls, seconds: float) -> Time:
        """The time ``seconds`` [s]."""
        return cls(seconds)

    @classmethod
    def now(cls) -> Time:
        """The wall clock (no ROS clock here)."""
        import time

        return cls(time.time())

    def to_sec(self) -> float:
        """The time in seconds [s]."""
        return self.secs + self.nsecs * 1e-9

    def to_nsec(self) -> int:
        """The time in nanoseconds."""
        return self.secs * 1_000_000_000 + self.nsecs

    def is_zero(self) -> bool:
        """Whether it is 0."""
        return self.secs == 0 and self.nsecs == 0

    def __sub__(self, other: Time) -> Duration:
        return Duration(self.to_sec() - other.to_sec())

    def __add__(self, other: Duration) -> Time:
        return type(self)(self.to_sec() + other.to_sec())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Time) and self.to_nsec() == other.to_nsec()

    def __lt__(self, other: Time) -> bool:
        return self.to_nsec() < other.to_nsec()

    def __hash__(self) -> int:
        return hash(self.to_nsec())

    def __float__(self) -> float:
        return self.to_sec()

    def __repr__(self) -> str:
        return f"{type(self).__name__}[{self.to_nsec()}]"


class Duration(Time):
    """``rospy.Duration``: a span of time."""

    __slots__ = ()

    def __sub__(self, other: Time) -> Duration:
        return Duration(self.to_sec() - other.to_sec())

    def __add__(self, other: Duration) -> Duration:
        return Duration(self.to_sec() + other.to_sec())


class Message:
    """A ROS message (see the module doc). Subclasses set ``__slots__``, ``_slot_types`` and
    ``_type``."""

    __slots__: ClassVar[tuple[str, ...]] = ()
    _slot_types: ClassVar[tuple[str, ...]] = ()
    _type: ClassVar[str] = ""
    _has_header: ClassVar[bool] = False

    def __init__(self, *args: Any, **kwds: Any) -> None:
        names = type(self).__slots__
        if args and kwds:
            raise TypeError(f"{self._type}(): give every field by position, or fields by name")
        if args and len(args) != len(names):
            raise TypeError(f"Invalid number of arguments, args should be {list(names)}")
        for name in kwds:
            if name not in names:
                raise AttributeError(f"{name} is not an attribute of {type(self).__name__}")
        for i, (name, kind) in enumerate(zip(names, type(self)._slot_types, strict=True)):
            if args:
                value = args[i]
            elif name in kwds:
                value = kwds[name]
            else:
                value = default_of(kind)
            object.__setattr__(self, name, value)

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return False
        return all(getattr(self, n) == getattr(other, n) for n in type(self).__slots__)

    __hash__ = None  # type: ignore[assignment]  # as genpy's: mutable, unhashable

    def __getstate__(self) -> list[Any]:
        return [getattr(self, n) for n in type(self).__slots__]

    def __setstate__(self, state: list[Any]) -> None:
        for n, v in zip(type(self).__slots__, state, strict=True):
            object.__setattr__(self, n, v)

    def __str__(self) -> str:
        return _yaml(self, "")

    __repr__ = __str__


def default_of(kind: str) -> Any:
    """The default value of a field of ROS type ``kind``."""
    if kind.endswith("]"):
        return []
    if kind in _NUMBERS:
        return 0.0
    if kind in _INTEGERS:
        return 0
    if kind == "bool":
        return False
    if kind == "string":
        return ""
    if kind == "time":
        return Time()
    if kind == "duration":
        return Duration()
    return MESSAGES[kind]()


def _yaml(value: Any, indent: str) -> str:
    """``value`` as genpy printed a message: ``name: value`` lines, nested ones indented."""
    if isinstance(value, Message):
        lines = []
        for name in type(value).__slots__:
            field = getattr(value, name)
            if isinstance(field, Message):
                lines.append(f"{indent}{name}: \n{_yaml(field, indent + '  ')}")
            elif isinstance(field, list | tuple) and field and isinstance(field[0], Message):
                items = "\n".join(f"{indent}  -\n{_yaml(item, indent + '    ')}" for item in field)
                lines.append(f"{indent}{name}: \n{items}")
            else:
                lines.append(f"{indent}{name}: {_scalar(field)}")
        return "\n".join(lines)
    return f"{indent}{_scalar(value)}"


def _scalar(value: Any) -> str:
    if isinstance(value, Time):
        return f"\n  secs: {value.secs}\n  nsecs: {value.nsecs}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(str(v) for v in value) + "]"
    return str(value)


#: Every message class by its ROS type name (``package/Name``).
MESSAGES: dict[str, type[Message]] = {}


def message(type_name: str, fields: str, **constants: Any) -> type[Message]:
    """A message class for ``type_name`` (``package/Name``) with ``fields`` (``"type name"``
    pairs separated by ``;``, as in a ``.msg`` file) and class-level ``constants``."""
    pairs = [f.split() for f in fields.split(";") if f.strip()]
    names = tuple(p[1] for p in pairs)
    kinds = tuple(_qualified(p[0], type_name) for p in pairs)
    cls = type(
        type_name.split("/")[1],
        (Message,),
        {
            "__slots__": names,
            "_slot_types": kinds,
            "_type": type_name,
            "_has_header": "header" in names,
            "__module__": __name__,  # pickles by its name here, with or without the shims
            **constants,
        },
    )
    MESSAGES[type_name] = cls
    return cls


def _qualified(kind: str, owner: str) -> str:
    """A field's type with its package (``Point`` in geometry_msgs is ``geometry_msgs/Point``;
    ``Header`` is ``std_msgs/Header``)."""
    base, bracket, rest = kind.partition("[")
    if base == "Header":
        base = "std_msgs/Header"
    elif "/" not in base and base not in _NUMBERS | _INTEGERS | {"bool", "string"}:
        if base not in ("time", "duration"):
            base = f"{owner.split('/')[0]}/{base}"
    return base + bracket + rest


# -- std_msgs ---------------------------------------------------------------------------------
Header = message("std_msgs/Header", "uint32 seq; time stamp; string frame_id")
Bool = message("std_msgs/Bool", "bool data")
Empty = message("std_msgs/Empty", "")
Float32 = message("std_msgs/Float32", "float32 data")
Float64 = message("std_msgs/Float64", "float64 data")
Int32 = message("std_msgs/Int32", "int32 data")
Int64 = message("std_msgs/Int64", "int64 data")
String = message("std_msgs/String", "string data")
ColorRGBA = message("std_msgs/ColorRGBA", "float32 r; float32 g; float32 b; float32 a")
Float64MultiArray = message("std_msgs/Float64MultiArray", "float64[] data")

# -- geometry_msgs ----------------------------------------------------------------------------
Point = message("geometry_msgs/Point", "float64 x; float64 y; float64 z")
Point32 = message("geometry_msgs/Point32", "float32 x; float32 y; float32 z")
Vector3 = message("geometry_msgs/Vector3", "float64 x; float64 y; float64 z")
Quaternion = message("geometry_msgs/Quaternion", "float64 x; float64 y; float64 z; float64 w")
Pose = message("geometry_msgs/Pose", "Point position; Quaternion orientation")
PoseStamped = message("geometry_msgs/PoseStamped", "Header header; Pose pose")
PoseArray = message("geometry_msgs/PoseArray", "Header header; Pose[] poses")
Transform = message("geometry_msgs/Transform", "Vector3 translation; Quaternion rotation")
TransformStamped = message(
    "geometry_msgs/TransformStamped", "Header header; string child_frame_id; Transform transform"
)
Twist = message("geometry_msgs/Twist", "Vector3 linear; Vector3 angular")
PointStamped = message("geometry_msgs/PointStamped", "Header header; Point point")

# -- trajectory_msgs, sensor_msgs, visualization_msgs -----------------------------------------
JointTrajectoryPoint = message(
    "trajectory_msgs/JointTrajectoryPoint",
    "float64[] positions; float64[] velocities; float64[] accelerations; float64[] effort; "
    "duration time_from_start",
)
JointTrajectory = message(
    "trajectory_msgs/JointTrajectory",
    "Header header; string[] joint_names; JointTrajectoryPoint[] points",
)
JointState = message(
    "sensor_msgs/JointState",
    "Header header; string[] name; float64[] position; float64[] velocity; float64[] effort",
)
Marker = message(
    "visualization_msgs/Marker",
    "Header header; string ns; int32 id; int32 type; int32 action; geometry_msgs/Pose pose; "
    "geometry_msgs/Vector3 scale; std_msgs/ColorRGBA color; duration lifetime; "
    "bool frame_locked; geometry_msgs/Point[] points; std_msgs/ColorRGBA[] colors; "
    "string text; string mesh_resource; bool mesh_use_embedded_materials",
    ARROW=0,
    CUBE=1,
    SPHERE=2,
    CYLINDER=3,
    LINE_STRIP=4,
    LINE_LIST=5,
    CUBE_LIST=6,
    SPHERE_LIST=7,
    POINTS=8,
    TEXT_VIEW_FACING=9,
    MESH_RESOURCE=10,
    TRIANGLE_LIST=11,
    ADD=0,
    MODIFY=0,
    DELETE=2,
    DELETEALL=3,
)
MarkerArray = message("visualization_msgs/MarkerArray", "Marker[] markers")

# -- kuka_arm/CalculateIK ---------------------------------------------------------------------
CalculateIKRequest = message("kuka_arm/CalculateIKRequest", "geometry_msgs/Pose[] poses")
CalculateIKResponse = message(
    "kuka_arm/CalculateIKResponse", "trajectory_msgs/JointTrajectoryPoint[] points"
)


class CalculateIK:
    """The exercise's service type, as ``kuka_arm.srv`` generated it."""

    _type = "kuka_arm/CalculateIK"
    _request_class = CalculateIKRequest
    _response_class = CalculateIKResponse


#: The messages each package's ``msg`` module exports (the shims re-export these).
PACKAGES: dict[str, tuple[str, ...]] = {}
for _name in MESSAGES:
    _package, _cls = _name.split("/")
    PACKAGES.setdefault(_package, ())
    PACKAGES[_package] += (_cls,)
