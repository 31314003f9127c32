"""A user's perception function in a process of its own, in the same jail as a student's IK:
a time limit per look, a memory limit, a scratch folder, and nothing left running afterwards.

:class:`PerceptionSandbox` is an :class:`~kr210_sim.sandbox.ik_sandbox.IkSandbox` whose process
runs :mod:`kr210_sim.sandbox.perception_child` instead: the same launch, limits, confinement,
deadlines and faults (a look with no answer within ``call_timeout`` is an
:class:`~kr210_sim.sandbox.ik_sandbox.IkTimeout`, a process that dies an
:class:`~kr210_sim.sandbox.ik_sandbox.IkCrashed`, and the next look starts a fresh process). A
look (:meth:`PerceptionSandbox.look`) crosses the pipe as one JSON frame of the wire
(:mod:`kr210_sim.sandbox.ik_wire`: the small items, and each image's dtype and shape) followed by
the images' raw bytes, written against the same deadline: a 640 x 480 RGB-D look is 2.1 MB, sent
without any encoding. :func:`open_perception` is what ``run --perception SPEC`` uses.
"""

from __future__ import annotations

import select
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError, IkSpecError, PerceptionSpecError
from kr210_sim.sandbox.confine import Confinement, Unconfined
from kr210_sim.sandbox.ik_sandbox import IkCrashed, IkSandbox, IkTimeout, Limits
from kr210_sim.sandbox.ik_wire import send
from kr210_sim.sandbox.perception_child import DTYPES, MAX_LOOK_BYTES
from kr210_sim.sandbox.user_perception import check_spec

#: Default time a look may take in the user's function [s].
DEFAULT_TIMEOUT = 10.0
#: Default memory limit of the user's process [MB]: NumPy, SciPy and two looks' copies fit.
DEFAULT_MEMORY_MB = 2048
#: The user's process: :func:`kr210_sim.sandbox.perception_child.serve`.
CHILD_MODULE = "kr210_sim.sandbox.perception_child"


def _write(fd: int, data: memoryview, until: float | None) -> None:
    """Write all of ``data`` to ``fd`` (non-blocking) before ``until`` (``time.monotonic()``).

    Raises:
        TimeoutError: It was not all written in time (the reader stopped reading).
    """
    import os

    blocking = os.get_blocking(fd)
    os.set_blocking(fd, False)
    try:
        while data:
            try:
                data = data[os.write(fd, data) :]
                continue
            except BlockingIOError:
                pass
            left = None if until is None else until - time.monotonic()
            if left is not None and left <= 0:
                raise TimeoutError
            if not select.select([], [fd], [], left)[1]:
                raise TimeoutError
    finally:
        os.set_blocking(fd, blocking)


class PerceptionSandbox(IkSandbox):
    """A user's perception function in a process of its own (see the module doc); takes the
    arguments of :class:`~kr210_sim.sandbox.ik_sandbox.IkSandbox`."""

    child, what = CHILD_MODULE, "perception"

    _arrays: tuple[npt.NDArray[Any], ...] = ()

    def _send(self, fd: int, message: dict[str, Any], until: float | None) -> None:
        """The request's frame, then its arrays' raw bytes."""
        send(fd, message, until)
        for a in self._arrays:
            _write(fd, a.data.cast("B"), until)

    def look(self, items: Mapping[str, Any], arrays: Mapping[str, npt.NDArray[Any]]) -> Any:
        """One call of the user's function on a look.

        Args:
            items: The look's small items (plain JSON types).
            arrays: Its images (sent C-contiguous, copied only when not), each of a dtype of
                :data:`~kr210_sim.sandbox.perception_child.DTYPES`.

        Returns:
            The answer's message (:func:`~kr210_sim.sandbox.user_perception.read_answer` reads
            it), or :class:`~kr210_sim.sandbox.ik_wire.Oversized`.

        Raises:
            ConfigError: The images are larger than
                :data:`~kr210_sim.sandbox.perception_child.MAX_LOOK_BYTES` or of another dtype.
            IkTimeout: No answer within ``call_timeout``.
            IkCrashed: The process died.
        """
        sent = tuple(np.ascontiguousarray(a) for a in arrays.values())
        if sum(a.nbytes for a in sent) > MAX_LOOK_BYTES:
            raise ConfigError(f"a look of over {MAX_LOOK_BYTES:,} bytes cannot be sent")
        if any(a.dtype.name not in DTYPES for a in sent):
            raise ConfigError(f"a look's images must be of {', '.join(DTYPES)}")
        specs = [
            {"name": name, "dtype": a.dtype.name, "shape": list(a.shape)}
            for name, a in zip(arrays, sent, strict=True)
        ]
        self._arrays = sent
        try:
            got = self._request({"look": dict(items), "arrays": specs}, self.limits.call_timeout)
        finally:
            self._arrays = ()
        return got

    def mark(self) -> tuple[int, int]:
        """Where a run starts: the looks asked and the faults so far (the process, and so its
        counts, outlive a run: one per SPEC in a process, see :func:`open_perception`)."""
        return self.calls, len(self.faults)

    def summary(self, since: tuple[int, int] = (0, 0)) -> dict[str, Any]:
        """The report's ``summary.perception.function``: the SPEC, what confined it, the looks
        it was asked and the faults (no answer in time, a crash; the first few), since
        ``since`` (a :meth:`mark`)."""
        return {
            "spec": self.spec,
            **self.confinement.describe(),
            "looks": self.calls - since[0],
            "timeout_s": self.limits.call_timeout,
            "faults": self.faults[since[1] :][:10],
        }


_OPEN: dict[tuple[str, float, bool], PerceptionSandbox] = {}


def open_perception(
    spec: str,
    timeout: float = DEFAULT_TIMEOUT,
    jail: bool | None = None,
    confinement: Confinement | None = None,
) -> PerceptionSandbox:
    """The sandbox of ``--perception SPEC [--perception-timeout S]``, started (so a bad SPEC is
    its one line now): in a jail (:class:`~kr210_sim.sandbox.jail.Jail`) unless ``jail`` is
    False (None: :func:`~kr210_sim.sandbox.jail.jail_wanted`, which ``--no-jail`` turns off),
    ``timeout`` per look, :data:`DEFAULT_MEMORY_MB` of memory. One per SPEC, limit and jail per
    process (``confinement`` given: a new one).

    Raises:
        PerceptionSpecError: The SPEC names nothing loadable, or its process did not start.
        JailUnavailable: A jail is wanted and none can be made here.
    """
    if not timeout > 0:
        raise ConfigError(f"--perception-timeout must be > 0 s, got {timeout}")
    where = check_spec(spec)[0]
    if where.endswith(".py") and not Path(where).is_file():
        raise PerceptionSpecError(f"--perception {spec!r}: no such file {where}")
    from kr210_sim.sandbox.jail import Jail, jail_wanted

    jailed = jail_wanted() if jail is None else jail
    key = (spec, float(timeout), jailed)
    if confinement is None and key in _OPEN:
        return _OPEN[key]
    made = confinement or (Jail() if jailed else Unconfined())
    limits = Limits(call_timeout=timeout, memory_mb=DEFAULT_MEMORY_MB)
    box = PerceptionSandbox(spec, limits, confinement=made)
    try:
        box.start()
    except IkSpecError as exc:
        box.close()
        raise PerceptionSpecError(str(exc)) from None
    except (IkTimeout, IkCrashed) as exc:
        box.close()
        raise PerceptionSpecError(f"--perception {spec!r}: {exc}") from None
    if confinement is None:
        _OPEN[key] = box
    return box
