"""The package's exception hierarchy.

Every error the library raises on purpose derives from :class:`Kr210SimError`, so the CLI can turn
it into a one-line message and an exit code. Messages say what went wrong and what to do.
"""

from __future__ import annotations

from typing import Any


class Kr210SimError(Exception):
    """Base class of every error raised on purpose by kr210_sim."""


class ConfigError(Kr210SimError, ValueError):
    """A configuration value or a command-line argument is invalid (a usage error)."""


class ActionError(ConfigError):
    """An action given to the Gymnasium environment is unusable: wrong shape, NaN or infinite
    entries, or entries outside the action space's box."""


class UnreachablePoseError(Kr210SimError, ValueError):
    """No inverse-kinematics solution exists inside the joint limits for a requested pose."""


class SceneError(Kr210SimError):
    """The URDF or MJCF scene is missing, malformed or inconsistent."""


class RenderError(Kr210SimError):
    """Offscreen rendering or video encoding is unavailable or failed."""


class VideoFailedError(RenderError):
    """The cycles ran and the report was written, but the video could not be made.

    Args:
        message: Why, in one line.
        report: The run's report (a :class:`kr210_sim.api.RunReport`).
    """

    def __init__(self, message: str, report: Any = None) -> None:
        super().__init__(message)
        self.report = report


class RecordingError(Kr210SimError):
    """A recording cannot be read (truncated, not a recording, an unknown format version, missing
    or inconsistent arrays) or was made with another model or MuJoCo version."""


class PlanningError(Kr210SimError):
    """A trajectory could not be planned (limits violated, ruckig failed, ...)."""


class IkSpecError(ConfigError):
    """An ``--ik`` SPEC names no loadable function (missing file or module, syntax error, no such
    function, not callable, or the module raised at import)."""


class PerceptionSpecError(ConfigError):
    """A ``--perception`` SPEC names no loadable function, or its process could not start."""


class IkFailedError(PlanningError):
    """A user-supplied IK function gave no usable answer for a pose the plan needs (it raised,
    returned something that is not six finite angles, left the joint limits, missed the pose or
    jumped branch between neighbouring straight-line samples)."""


class UnservableCellError(ConfigError):
    """No slot of a cell can be served; ``table`` is the check's table (printed before the
    one-line message)."""

    def __init__(self, message: str, table: str) -> None:
        super().__init__(message)
        self.table = table


class NoPathError(PlanningError):
    """No collision-free plan exists for a move (the detail names what blocks)."""


class NotSeenError(PlanningError):
    """``run --perceive``: no look found the cycle's target (the detail says what was seen)."""


def one_line(text: object) -> str:
    """``text`` as one line: every run of white space (newlines included) becomes one space.

    Error messages are printed one line each; MuJoCo's and user code's messages often span
    several. An exception without a message gives its type's name.
    """
    line = " ".join(str(text).split())
    if not line and isinstance(text, BaseException):
        return type(text).__name__
    return line
