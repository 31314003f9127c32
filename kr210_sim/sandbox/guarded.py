"""The user's IK a command asks for (``--ik SPEC [--ik-timeout S] [--ik-root DIR]``): imported
here, or started in an :class:`~kr210_sim.sandbox.ik_sandbox.IkSandbox` (jailed unless
``--no-jail``), once per SPEC, limit, jail and root in a process."""

from __future__ import annotations

from pathlib import Path

from kr210_sim.errors import ConfigError, IkSpecError
from kr210_sim.exercise.form import is_ros_form, resolve_spec
from kr210_sim.sandbox.confine import Unconfined
from kr210_sim.sandbox.ik_sandbox import (
    LOAD_TIMEOUT,
    ROS_LOAD_TIMEOUT,
    IkCrashed,
    IkSandbox,
    IkTimeout,
    Limits,
)
from kr210_sim.sandbox.user_ik import UserIk, load_ik, spec_file

_GUARDED: dict[tuple[str, float | None, bool, Path | None], UserIk] = {}


def load_user_ik(
    spec: str, timeout: float | None = None, jail: bool | None = None, root: Path | None = None
) -> UserIk:
    """The user's IK for ``--ik SPEC [--ik-timeout S]``.

    Without ``timeout`` it is imported here (:func:`~kr210_sim.sandbox.user_ik.load_ik`). With
    one it runs in an :class:`IkSandbox` (``stop=False``, no memory limit, its output to ours),
    in a jail (:class:`~kr210_sim.sandbox.jail.Jail`) unless ``jail`` is False (None:
    :func:`~kr210_sim.sandbox.jail.jail_wanted`, which ``--no-jail`` turns off), started here so a
    bad SPEC is its one line now; a call with no answer within ``timeout`` raises
    :class:`IkTimeout` ("no answer within 2 s"), which the checks turn into an unusable answer
    (that cycle is ``ik_failed``). One sandbox per SPEC, limit, jail and process. A ROS-form
    server always runs in a sandbox (a process of its own, its working folder holding a copy of
    the files beside it, as under ``rosrun``), with no limit per call unless ``timeout`` sets
    one, and :data:`ROS_LOAD_TIMEOUT` to reach ``rospy.spin()``. ``root`` (``--ik-root``): the
    folder of the user's own files its jail shows, instead of a file SPEC's file alone.

    Raises:
        ConfigError: ``root`` for an IK that would run in this process (no ``timeout``).
        IkSpecError: The SPEC names nothing loadable, or its import took longer than
            :data:`~kr210_sim.sandbox.ik_sandbox.LOAD_TIMEOUT`.
        JailUnavailable: A jail is wanted and none can be made here.
    """
    spec = resolve_spec(spec)
    source = spec_file(spec)
    ros = source is not None and is_ros_form(source)
    if timeout is None and not ros:
        if root is not None:
            raise ConfigError(
                "--ik-root needs --ik-timeout: without it your IK runs in this process"
            )
        return load_ik(spec)
    from kr210_sim.sandbox.jail import Jail, jail_wanted

    jailed = jail_wanted() if jail is None else jail
    key = (spec, None if timeout is None else float(timeout), jailed, root)
    if key not in _GUARDED:
        confinement = Jail() if jailed else Unconfined()
        load = ROS_LOAD_TIMEOUT if ros else LOAD_TIMEOUT
        limits = Limits(call_timeout=timeout, memory_mb=None, load_timeout=load)
        box = IkSandbox(spec, limits, confinement=confinement, root=root)
        try:
            box.start()
        except (IkTimeout, IkCrashed) as exc:
            box.close()
            raise IkSpecError(f"--ik {spec!r}: {exc}") from None
        _GUARDED[key] = box.user_ik()
    return _GUARDED[key]
