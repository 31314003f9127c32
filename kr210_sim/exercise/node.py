"""rospy without ROS: what IK servers call, doing here what it did for them.

``rospy`` (the shim in ``shims/rospy``) is this module. A node has no master, no topics and no
other services: ``init_node`` records the name; ``loginfo`` and the other loggers print as rospy
printed (``[INFO] [time]: message``, with ``msg % args``); ``Publisher.publish`` sends nowhere;
a ``Subscriber``'s callback is never called; ``get_param`` answers from the parameters set here
(or the default; without one a ``KeyError`` naming the parameter, as rospy's).

``Service(name, CalculateIK, handler)`` registers the handler, and ``spin()`` (also
``Service.spin()``, and ``is_shutdown()``, ``sleep`` or ``Rate.sleep`` called once a service is
registered: a server's ``while not rospy.is_shutdown()`` loop) is where the script hands over: the
serving loop that :mod:`kr210_sim.exercise.server` installs (:func:`set_serve`) runs there and
never returns, so everything the script built before it (``IK_server()``'s locals, globals,
class instances) lives on while it serves. Without a serving loop (the script imported, not run),
these calls return at once.
"""

from __future__ import annotations

import sys
import threading
import time as _time
from collections.abc import Callable
from typing import Any

from kr210_sim.exercise.messages import Duration, Time

__all__ = [
    "DEBUG",
    "ERROR",
    "FATAL",
    "INFO",
    "WARN",
    "Duration",
    "Publisher",
    "ROSException",
    "ROSInitException",
    "ROSInterruptException",
    "ROSSerializationException",
    "Rate",
    "Service",
    "ServiceException",
    "ServiceProxy",
    "Subscriber",
    "Time",
    "delete_param",
    "get_caller_id",
    "get_name",
    "get_namespace",
    "get_param",
    "get_param_names",
    "get_published_topics",
    "get_rostime",
    "get_time",
    "has_param",
    "init_node",
    "is_shutdown",
    "logdebug",
    "logdebug_once",
    "logdebug_throttle",
    "logerr",
    "logerr_once",
    "logerr_throttle",
    "logfatal",
    "loginfo",
    "loginfo_once",
    "loginfo_throttle",
    "logwarn",
    "logwarn_once",
    "logwarn_throttle",
    "myargv",
    "on_shutdown",
    "resolve_name",
    "search_param",
    "set_param",
    "signal_shutdown",
    "sleep",
    "spin",
    "wait_for_message",
    "wait_for_service",
]

DEBUG, INFO, WARN, ERROR, FATAL = 1, 2, 4, 8, 16


class ROSException(Exception):
    """rospy's base exception."""


class ROSInitException(ROSException):
    """A node could not start."""


class ROSInterruptException(ROSException, KeyboardInterrupt):
    """The node was shut down."""


class ROSSerializationException(ROSException):
    """A message could not be serialized."""


class ServiceException(Exception):
    """A service call failed."""


# -- the node ---------------------------------------------------------------------------------
_state: dict[str, Any] = {
    "name": "/unnamed",
    "params": {},
    "services": {},
    "serve": None,
    "served": False,
    "shutdown": False,
    "once": set(),
    "last": {},
}
_lock = threading.Lock()


def set_serve(serve: Callable[[], None] | None) -> None:
    """A fresh node (no services, parameters or logging state) whose ``spin()`` hands over to
    the serving loop ``serve`` (None: ``spin()`` returns at once). A server that serves already
    keeps the handler it serves."""
    _state.update(
        name="/unnamed", params={}, services={}, serve=serve, served=False, shutdown=False
    )
    _state["once"] = set()
    _state["last"] = {}


def services() -> dict[str, Service]:
    """The services registered so far, by name."""
    return dict(_state["services"])


def _hand_over() -> None:
    """Run the serving loop, once: it does not return (it ends with the process)."""
    serve = _state["serve"]
    with _lock:
        if serve is None or _state["served"] or not _state["services"]:
            return
        _state["served"] = True
    serve()


def init_node(name: str, argv: Any = None, anonymous: bool = False, **kwargs: Any) -> None:
    """Name the node (``anonymous`` adds a number, as rospy did)."""
    base = name if name.startswith("/") else f"/{name}"
    _state["name"] = f"{base}_{int(_time.time() * 1000)}" if anonymous else base


def get_name() -> str:
    """The node's name (``/IK_server``)."""
    return str(_state["name"])


get_caller_id = get_name


def get_namespace() -> str:
    """The node's namespace (``/``)."""
    return "/"


def resolve_name(name: str, caller_id: str | None = None) -> str:
    """``name`` resolved as rospy did: ``~x`` in the node's namespace, ``x`` in ``/``."""
    if name.startswith("~"):
        return f"{get_name()}/{name[1:]}"
    return name if name.startswith("/") else f"/{name}"


def myargv(argv: list[str] | None = None) -> list[str]:
    """``argv`` without ROS's remapping arguments (``name:=value``)."""
    return [a for a in (sys.argv if argv is None else argv) if ":=" not in a]


def is_shutdown() -> bool:
    """False while serving; the first call once a service is registered serves."""
    _hand_over()
    return bool(_state["shutdown"])


def signal_shutdown(reason: str) -> None:
    """Mark the node shut down."""
    _state["shutdown"] = True


def on_shutdown(hook: Callable[..., Any]) -> None:
    """Hooks are never called: the node's process is killed when grading ends."""


def spin() -> None:
    """Hand over to the serving loop (see the module doc)."""
    _hand_over()


def sleep(duration: float | Duration) -> None:
    """Hand over to the serving loop when a service is registered, else sleep."""
    _hand_over()
    _time.sleep(max(0.0, float(duration)))


class Rate:
    """``rospy.Rate(hz)``: ``sleep()`` keeps a loop at ``hz`` (and serves, as :func:`sleep`)."""

    def __init__(self, hz: float, reset: bool = False) -> None:
        self.period = 1.0 / float(hz)
        self.last = _time.monotonic()

    def sleep(self) -> None:
        """Sleep what is left of the period."""
        _hand_over()
        left = self.period - (_time.monotonic() - self.last)
        if left > 0:
            _time.sleep(left)
        self.last = _time.monotonic()

    def remaining(self) -> Duration:
        """What is left of the period."""
        return Duration(max(0.0, self.period - (_time.monotonic() - self.last)))


def get_time() -> float:
    """The wall clock [s] (no ROS clock here)."""
    return _time.time()


def get_rostime() -> Time:
    """The wall clock as a :class:`Time`."""
    return Time.now()


# -- logging ----------------------------------------------------------------------------------
def _log(level: str, msg: Any, args: tuple[Any, ...], stream: Any) -> None:
    text = str(msg) % args if args else str(msg)
    stream.write(f"[{level}] [{_time.time():.6f}]: {text}\n")
    stream.flush()


def logdebug(msg: Any, *args: Any, **kwargs: Any) -> None:
    """Debug messages are not shown (rospy's default level is INFO)."""


def loginfo(msg: Any, *args: Any, **kwargs: Any) -> None:
    """``[INFO] [time]: msg % args`` on stdout."""
    _log("INFO", msg, args, sys.stdout)


def logwarn(msg: Any, *args: Any, **kwargs: Any) -> None:
    """``[WARN] [time]: msg % args`` on stderr."""
    _log("WARN", msg, args, sys.stderr)


def logerr(msg: Any, *args: Any, **kwargs: Any) -> None:
    """``[ERROR] [time]: msg % args`` on stderr."""
    _log("ERROR", msg, args, sys.stderr)


def logfatal(msg: Any, *args: Any, **kwargs: Any) -> None:
    """``[FATAL] [time]: msg % args`` on stderr."""
    _log("FATAL", msg, args, sys.stderr)


def _once(log: Callable[..., None]) -> Callable[..., None]:
    def once(msg: Any, *args: Any, **kwargs: Any) -> None:
        key = (log.__name__, str(msg))
        if key not in _state["once"]:
            _state["once"].add(key)
            log(msg, *args)

    return once


def _throttle(log: Callable[..., None]) -> Callable[..., None]:
    def throttle(period: float, msg: Any, *args: Any, **kwargs: Any) -> None:
        key = (log.__name__, str(msg))
        now = _time.monotonic()
        if now - _state["last"].get(key, -1e18) >= float(period):
            _state["last"][key] = now
            log(msg, *args)

    return throttle


logdebug_once, loginfo_once = _once(logdebug), _once(loginfo)
logwarn_once, logerr_once = _once(logwarn), _once(logerr)
logdebug_throttle, loginfo_throttle = _throttle(logdebug), _throttle(loginfo)
logwarn_throttle, logerr_throttle = _throttle(logwarn), _throttle(logerr)


# -- parameters -------------------------------------------------------------------------------
_NO_DEFAULT = object()


def get_param(name: str, default: Any = _NO_DEFAULT) -> Any:
    """The parameter ``name``, or ``default``; without one a ``KeyError`` naming it."""
    key = resolve_name(name)
    if key in _state["params"]:
        return _state["params"][key]
    if default is _NO_DEFAULT:
        raise KeyError(key)
    return default


def set_param(name: str, value: Any) -> None:
    """Set the parameter ``name``."""
    _state["params"][resolve_name(name)] = value


def has_param(name: str) -> bool:
    """Whether the parameter ``name`` is set."""
    return resolve_name(name) in _state["params"]


def delete_param(name: str) -> None:
    """Delete the parameter ``name`` (``KeyError`` when it is not set, as rospy's)."""
    del _state["params"][resolve_name(name)]


def search_param(name: str) -> str | None:
    """The parameter's full name when it is set, else None."""
    key = resolve_name(name)
    return key if key in _state["params"] else None


def get_param_names() -> list[str]:
    """The names of the parameters set."""
    return sorted(_state["params"])


# -- topics and services ----------------------------------------------------------------------
class Publisher:
    """A publisher with no subscribers: ``publish`` sends nowhere."""

    def __init__(self, name: str, data_class: Any, *args: Any, **kwargs: Any) -> None:
        self.name = resolve_name(name)
        self.data_class = data_class

    def publish(self, *args: Any, **kwargs: Any) -> None:
        """Nobody listens."""

    def get_num_connections(self) -> int:
        """No subscribers."""
        return 0

    def unregister(self) -> None:
        """Nothing to undo."""


class Subscriber:
    """A subscriber to a topic nobody publishes: its callback is never called."""

    def __init__(self, name: str, data_class: Any, callback: Any = None, *a: Any, **k: Any) -> None:
        self.name = resolve_name(name)
        self.data_class = data_class
        self.callback = callback

    def unregister(self) -> None:
        """Nothing to undo."""


def get_published_topics(namespace: str = "/") -> list[list[str]]:
    """No topics."""
    return []


def wait_for_message(topic: str, topic_type: Any, timeout: float | None = None) -> Any:
    """No message will come: ``ROSException`` at once."""
    raise ROSException(f"no message on {topic}: kr210_sim runs no ROS topics")


class Service:
    """A service: ``handler(request)`` answers it (see the module doc).

    Args:
        name: The service's name (``calculate_ik``).
        service_class: Its type (``CalculateIK``).
        handler: What answers it: ``handler(request) -> response``.
    """

    def __init__(self, name: str, service_class: Any, handler: Callable[..., Any], *a: Any,
                 **k: Any) -> None:  # fmt: skip
        self.resolved_name = resolve_name(name)
        self.service_class = service_class
        self.handler = handler
        _state["services"][self.resolved_name] = self

    def spin(self) -> None:
        """Hand over to the serving loop, as :func:`spin`."""
        _hand_over()

    def shutdown(self, reason: str = "") -> None:
        """Unregister the service."""
        _state["services"].pop(self.resolved_name, None)


def wait_for_service(service: str, timeout: float | None = None) -> None:
    """Return for a service this node registered; any other is not there: ``ROSException``."""
    if resolve_name(service) not in _state["services"]:
        raise ROSException(f"service {service} is not available: kr210_sim runs no other nodes")


class ServiceProxy:
    """A client of a service: this node's own is called directly, any other is not there."""

    def __init__(self, name: str, service_class: Any, *args: Any, **kwargs: Any) -> None:
        self.resolved_name = resolve_name(name)
        self.service_class = service_class

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        service = _state["services"].get(self.resolved_name)
        if service is None:
            raise ServiceException(f"service {self.resolved_name} is not available")
        request = self.service_class._request_class(*args, **kwargs)
        return service.handler(request)

    call = __call__

    def wait_for_service(self, timeout: float | None = None) -> None:
        """As :func:`wait_for_service`."""
        wait_for_service(self.resolved_name, timeout)

    def close(self) -> None:
        """Nothing to undo."""
