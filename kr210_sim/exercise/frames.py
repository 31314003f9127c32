"""``tf`` and ``tf2_ros`` frames without a tf tree: what IK servers used of them.

IK servers broadcast frames for RViz (``TransformBroadcaster.sendTransform``: sent nowhere) and
rarely look one up. There is no tf tree here: a lookup finds only a transform this process set
itself (``Transformer.setTransform``, ``Buffer.set_transform``), else it raises tf's
``LookupException`` naming the frames, as tf did for frames nobody published.
"""

from __future__ import annotations

from typing import Any


class TransformException(Exception):
    """tf2's base exception (``tf.Exception`` in tf)."""


class LookupException(TransformException):
    """A frame nobody publishes."""


class ConnectivityException(TransformException):
    """Frames that are not connected."""


class ExtrapolationException(TransformException):
    """A time outside the buffer."""


class InvalidArgumentException(TransformException):
    """A malformed request."""


class TimeoutException(TransformException):
    """A lookup that timed out."""


def _missing(target: str, source: str) -> LookupException:
    return LookupException(
        f'"{target}" passed to lookupTransform argument target_frame does not exist (no tf '
        f"tree here: kr210_sim runs no robot_state_publisher; looked for {source} -> {target})"
    )


class Transformer:
    """tf's transformer: lookups of the transforms set here."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._set: dict[tuple[str, str], Any] = {}

    def setTransform(self, transform: Any, authority: str = "") -> None:
        """Remember ``transform`` (a ``TransformStamped``) for lookups."""
        key = (
            str(transform.header.frame_id).lstrip("/"),
            str(transform.child_frame_id).lstrip("/"),
        )
        self._set[key] = transform

    def lookupTransform(self, target: str, source: str, time: Any) -> Any:
        """``((x, y, z), (qx, qy, qz, qw))`` of ``source`` in ``target``, when it was set."""
        t = self._set.get((target.lstrip("/"), source.lstrip("/")))
        if t is None:
            raise _missing(target, source)
        tr, rot = t.transform.translation, t.transform.rotation
        return (tr.x, tr.y, tr.z), (rot.x, rot.y, rot.z, rot.w)

    def canTransform(self, target: str, source: str, time: Any) -> bool:
        """Whether the transform was set here."""
        return (target.lstrip("/"), source.lstrip("/")) in self._set

    def waitForTransform(self, target: str, source: str, time: Any, timeout: Any) -> None:
        """Raise at once for a transform not set here (none will come)."""
        if not self.canTransform(target, source, time):
            raise _missing(target, source)

    def getFrameStrings(self) -> list[str]:
        """The frames of the transforms set here."""
        return sorted({f for pair in self._set for f in pair})


class TransformListener(Transformer):
    """tf's listener (and tf2_ros's, given a buffer): hears no frames."""

    def __init__(self, buffer: Any = None, *args: Any, **kwargs: Any) -> None:
        super().__init__()
        self.buffer = buffer


class TransformBroadcaster:
    """Broadcasts frames to nobody."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        pass

    def sendTransform(self, *args: Any, **kwargs: Any) -> None:
        """Nobody listens."""


StaticTransformBroadcaster = TransformBroadcaster


class Buffer:
    """tf2_ros's buffer: lookups of the transforms set here."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._transformer = Transformer()

    def set_transform(self, transform: Any, authority: str = "") -> bool:
        """Remember ``transform`` for lookups."""
        self._transformer.setTransform(transform, authority)
        return True

    def lookup_transform(self, target: str, source: str, time: Any, timeout: Any = None) -> Any:
        """The ``TransformStamped`` set here, else ``LookupException``."""
        t = self._transformer._set.get((target.lstrip("/"), source.lstrip("/")))
        if t is None:
            raise _missing(target, source)
        return t

    def can_transform(self, target: str, source: str, time: Any, timeout: Any = None) -> bool:
        """Whether the transform was set here."""
        return self._transformer.canTransform(target, source, time)
