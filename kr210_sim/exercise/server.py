"""Run a ROS-form ``IK_server.py`` as ROS ran it, and serve its handler our poses.

:class:`RosServer` starts the script in a thread of its own as ``__main__`` (its folder first on
``sys.path``, as under ``rosrun``), with:

* the ROS modules it imports (``shims/``: rospy, tf, tf2_ros, kuka_arm.srv, the message
  packages) first on ``sys.path``; an import of a ROS package that is not there is one line
  naming it;
* its own modules (beside it, and in the repository's ``src`` folders) read as Python 2 by an
  import hook (:mod:`kr210_sim.exercise.py2`), never written back;
* the libraries' old names (:mod:`kr210_sim.exercise.legacy`).

When the script reaches ``rospy.spin()`` (or its loop of ``rospy.is_shutdown()``), the handler
it registered with ``rospy.Service`` is served there, in the script's own thread: everything the
script built before is alive, and one process serves every request, so globals persist as they
did under ROS. A script that ends without spinning is served by its registered handler or, with
none, by its module-level function named by the SPEC (``handle_calculate_IK``).

Requests go as MoveIt sent them: many poses in one ``CalculateIK`` request (:meth:`RosServer.
batch`). When the handler raises, the pose it was reading gets the exception and the poses
before and after it are asked again in requests of their own, so one bad pose loses no other;
when it raised after reading every pose, or answered with another number of points than poses,
each pose is asked alone.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import queue
import sys
import threading
import traceback
import types
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import IkSpecError, one_line
from kr210_sim.exercise import answers, legacy, node, packages
from kr210_sim.exercise.py2 import Notes, compile_py2, runtime

FloatArray = npt.NDArray[np.float64]

#: The ROS modules' shims (a folder of top-level packages).
SHIMS = Path(__file__).resolve().parent / "shims"
#: The ROS packages the shims provide.
PROVIDED = (
    "rospy",
    "tf",
    "tf2_ros",
    "kuka_arm.srv",
    "geometry_msgs.msg",
    "std_msgs.msg",
    "trajectory_msgs.msg",
    "sensor_msgs.msg",
    "visualization_msgs.msg",
    "roslib",
)
#: Module names that are ROS packages (besides ``*_msgs``, ``*_srvs``, ``ros*``, ``moveit*``).
ROS_PACKAGES = frozenset(
    "actionlib angles cv_bridge dynamic_reconfigure genpy image_geometry interactive_markers "
    "kdl_parser_py kuka_arm laser_geometry message_filters pcl PyKDL resource_retriever "
    "tf_conversions tf2_geometry_msgs tf2_py urdf_parser_py xacro gazebo_ros".split()
)
#: The service the exercise's MoveIt plugin called.
SERVICE = "/calculate_ik"


def is_ros_package(name: str) -> bool:
    """Whether module ``name`` belongs to a ROS package (not a Python library)."""
    top = name.split(".")[0]
    return (
        top in ROS_PACKAGES
        or top.endswith(("_msgs", "_srvs"))
        or top.startswith(("ros", "moveit", "gazebo"))
    )


# -- the student's own modules ----------------------------------------------------------------
class _Py2Loader(importlib.machinery.SourceFileLoader):
    """Loads a student's module as Python 2 (compiled from source each time, nothing written)."""

    def __init__(self, fullname: str, path: str, in_package: bool, notes: Notes) -> None:
        super().__init__(fullname, path)
        self.in_package = in_package
        self.notes = notes
        self.was_py2 = True

    def get_code(self, fullname: str) -> types.CodeType:
        code, self.was_py2 = compile_py2(self.get_data(self.path), self.path, self.in_package)
        return code

    def set_data(self, path: str, data: Any, *, _mode: int = 0o666) -> None:
        """Nothing is written beside the student's files."""

    def exec_module(self, module: types.ModuleType) -> None:
        code = self.get_code(module.__name__)
        if self.was_py2:
            module.__dict__.update(runtime(Path(self.path).name, self.notes))
        exec(code, module.__dict__)


class _StudentFinder(importlib.abc.MetaPathFinder):
    """Finds the students' modules (in the folders given to :meth:`add`, or in a package found
    there) for :class:`_Py2Loader`; everything else is left to Python. One per process."""

    def __init__(self) -> None:
        self.roots: dict[Path, Notes] = {}

    def add(self, roots: Sequence[Path], notes: Notes) -> None:
        """Read the modules in ``roots`` as Python 2, noting into ``notes``."""
        for r in roots:
            self.roots[r.resolve()] = notes

    def _notes(self, origin: str) -> Notes | None:
        where = Path(origin).resolve()
        return next((n for r, n in self.roots.items() if where.is_relative_to(r)), None)

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> Any:
        search = [str(r) for r in self.roots] if path is None else path
        spec = importlib.machinery.PathFinder.find_spec(fullname, search)
        if spec is None or not spec.origin or not spec.origin.endswith(".py"):
            return None
        notes = self._notes(spec.origin)
        if notes is None:
            return None
        in_package = "." in fullname or spec.submodule_search_locations is not None
        spec.loader = _Py2Loader(fullname, spec.origin, in_package, notes)
        return spec


def _finder() -> _StudentFinder:
    for f in sys.meta_path:
        if isinstance(f, _StudentFinder):
            return f
    finder = _StudentFinder()
    sys.meta_path.insert(0, finder)
    return finder


# -- the server -------------------------------------------------------------------------------
@dataclass
class _Job:
    poses: list[FloatArray]
    done: threading.Event = field(default_factory=threading.Event)
    result: list[Any] = field(default_factory=list)
    error: BaseException | None = None


class _Raised(Exception):
    """The handler raised ``error`` with pose ``last`` (of its request) the last it read."""

    def __init__(self, error: BaseException, last: int) -> None:
        super().__init__(str(error))
        self.error = error
        self.last = last


class _Miscount(Exception):
    """The handler answered a request of several poses with another number of points."""


#: Exceptions that end the process rather than a request.
_FATAL = (SystemExit, KeyboardInterrupt, MemoryError)


class RosServer:
    """A ROS-form server script, started and served (see the module doc).

    Args:
        script: The ``IK_server.py`` file.
        spec: The SPEC it was named by (for messages).
        fallback: The module-level handler served when the script registers none.
        roots: The student's own folders, whose modules are read as Python 2 (default: the
            script's folder, and the ``src`` folder beside that folder, a catkin package's).
    """

    def __init__(
        self, script: Path, spec: str, fallback: str, roots: Sequence[Path] | None = None
    ) -> None:
        self.script = script
        self.spec = spec
        self.fallback = fallback
        folder = script.resolve().parent
        self.roots = list(roots) if roots is not None else _default_roots(folder)
        self.notes = Notes()
        self.module: types.ModuleType | None = None
        self._jobs: queue.Queue[_Job] = queue.Queue()
        self._ready: queue.Queue[BaseException | None] = queue.Queue()
        self._saved: dict[str, Any] = {}

    # ------------------------------------------------------------------ starting
    def start(self) -> None:
        """Run the script until it serves.

        Raises:
            IkSpecError: One line: it cannot be read as Python 2, imports a ROS package that is
                not here, raised, or registers no handler and defines no fallback.
        """
        if not self.script.is_file():
            raise IkSpecError(f"--ik {self.spec!r}: no such file {self.script}")
        legacy.install()
        for folder in (*reversed(self.roots), SHIMS):
            if str(folder) in sys.path:
                sys.path.remove(str(folder))
            sys.path.insert(0, str(folder))
        _finder().add(self.roots, self.notes)
        packages.install(self.script)
        node.set_serve(self._serve_registered)
        thread = threading.Thread(target=self._main, name="IK_server", daemon=True)
        thread.start()
        failure = self._ready.get()
        if failure is not None:
            raise failure

    def _main(self) -> None:
        """The script's thread: run it; serve from ``spin()``, or after it ended."""
        try:
            code, was_py2 = compile_py2(self.script.read_bytes(), str(self.script))
        except IkSpecError as exc:
            self._ready.put(IkSpecError(f"--ik {self.spec!r}: {exc}"))
            return
        except OSError as exc:
            self._ready.put(IkSpecError(f"--ik {self.spec!r}: cannot read {self.script}: {exc}"))
            return
        module = types.ModuleType("__main__")
        module.__file__ = str(self.script)
        module.__dict__["__builtins__"] = __builtins__
        if was_py2:
            module.__dict__.update(runtime(self.script.name, self.notes))
        self.module = module
        self._saved = {"argv": sys.argv, "main": sys.modules.get("__main__")}
        sys.argv = [str(self.script)]
        sys.modules["__main__"] = module
        try:
            exec(code, module.__dict__)
        except BaseException as exc:
            self._restore()
            self._ready.put(self._import_failure(exc))
            return
        self._restore()
        handler = self._registered() or module.__dict__.get(self.fallback)
        if not callable(handler):
            names = ", ".join(node.services()) or "none"
            self._ready.put(
                IkSpecError(
                    f"--ik {self.spec!r}: {self.script.name} registered no service with "
                    f"rospy.Service (services: {names}) and defines no {self.fallback}(req)"
                )
            )
            return
        self._loop(handler)

    def _restore(self) -> None:
        if self._saved:
            sys.argv = self._saved["argv"]
            if self._saved["main"] is not None:
                sys.modules["__main__"] = self._saved["main"]
            self._saved = {}

    def _registered(self) -> Callable[..., Any] | None:
        found = node.services()
        service = found.get(SERVICE) or (next(iter(found.values())) if len(found) == 1 else None)
        return service.handler if service is not None else None

    def _serve_registered(self) -> None:
        """``rospy.spin()``: serve the registered handler here, in the script's thread."""
        handler = self._registered()
        if handler is None:
            return
        self._restore()
        self._loop(handler)

    def _import_failure(self, exc: BaseException) -> BaseException:
        where = self._where(exc)
        if isinstance(exc, IkSpecError):
            return IkSpecError(f"--ik {self.spec!r}: {exc}")
        if isinstance(exc, ModuleNotFoundError) and exc.name:
            if is_ros_package(exc.name):
                return IkSpecError(
                    f"--ik {self.spec!r}: {where or self.script.name} imports {exc.name}, a ROS "
                    f"package kr210_sim does not provide (it provides {', '.join(PROVIDED)}, and "
                    "the .msg and .srv types of the repository's own catkin packages)"
                )
            return IkSpecError(
                f"--ik {self.spec!r}: {where or self.script.name} imports {exc.name}, which is "
                "not installed here"
            )
        if isinstance(exc, _FATAL):
            return exc
        text = f"{type(exc).__name__}: {one_line(str(exc))}" if str(exc) else type(exc).__name__
        at = f" ({where})" if where else ""
        return IkSpecError(f"--ik {self.spec!r}: running {self.script.name} raised {text}{at}")

    def _where(self, exc: BaseException) -> str:
        """``file line N`` of the innermost frame of ``exc``'s traceback in the student's
        files ("" when none is)."""
        roots = [r.resolve() for r in self.roots]
        found = ""
        for frame in traceback.extract_tb(exc.__traceback__):
            try:
                path = Path(frame.filename).resolve()
            except (OSError, ValueError):
                continue
            if any(path.is_relative_to(r) for r in roots):
                found = f"{path.name} line {frame.lineno}"
        return found

    # ------------------------------------------------------------------ serving
    def _loop(self, handler: Callable[..., Any]) -> None:
        """Answer jobs for ever (the thread ends with the process)."""
        self._ready.put(None)
        while True:
            job = self._jobs.get()
            try:
                job.result = self._solve_many(handler, job.poses)
            except BaseException as exc:  # fatal: the caller's process ends with it
                job.error = exc
            job.done.set()

    def _ask(self, handler: Callable[..., Any], poses: list[FloatArray]) -> list[Any]:
        """One request: an answer per pose. Raises :class:`_Raised` when the handler raised
        (or returned what rospy refused), and :class:`_Miscount` for another number of points."""
        req = answers.request(poses)
        try:
            returned = handler(req)
            got = answers.points(returned)
        except _FATAL:
            raise
        except answers.ServiceError as exc:
            raise _Raised(exc, len(poses)) from None
        except BaseException as exc:
            raise _Raised(self._located(exc), req.poses.last) from None
        if len(got) != len(poses):
            if len(poses) == 1:
                if not got:
                    return [None]  # no point for the pose: it found no solution
                return [answers.unusable(f"{len(got)} points", "one point per pose")]
            raise _Miscount(len(got))
        return [answers.angles(p) for p in got]

    def _solve_many(self, handler: Callable[..., Any], poses: list[FloatArray]) -> list[Any]:
        out: list[Any] = [None] * len(poses)

        def run(idx: list[int]) -> None:
            if not idx:
                return
            try:
                got = self._ask(handler, [poses[i] for i in idx])
            except _Raised as exc:
                k = exc.last
                if len(idx) == 1 or not 0 <= k < len(idx):
                    # alone; raised before reading a pose; or refused after it returned: each
                    for i in idx:
                        out[i] = exc.error
                    return
                if k == len(idx) - 1:  # at the last pose, or after the loop: each alone
                    for i in idx:
                        run([i])
                    return
                out[idx[k]] = exc.error
                run(idx[:k])
                run(idx[k + 1 :])
                return
            except _Miscount:
                for i in idx:
                    run([i])
                return
            for i, a in zip(idx, got, strict=True):
                out[i] = a

        run(list(range(len(poses))))
        return out

    def _located(self, exc: BaseException) -> BaseException:
        """``exc`` as the student's error: its type (a subclass of it, where one can be made),
        its message and where in the student's code it was raised."""
        where = self._where(exc)
        text = one_line(str(exc))
        text = f"{text} ({where})" if where else text
        attrs = {"__str__": lambda self: text, "__module__": type(exc).__module__}
        try:
            located = type(type(exc).__name__, (type(exc),), attrs)(text)
        except Exception:  # a type that takes other arguments, or cannot be subclassed
            located = type(type(exc).__name__, (Exception,), attrs)(text)
        return located

    def batch(self, poses: Sequence[FloatArray]) -> list[Any]:
        """One answer per pose (six floats, None, an unusable answer, or the exception the
        handler raised on it), the poses sent as one request (see the module doc)."""
        job = _Job([np.asarray(T, dtype=np.float64).reshape(4, 4) for T in poses])
        self._jobs.put(job)
        job.done.wait()
        if job.error is not None:
            raise job.error
        return job.result

    def solve(self, T: FloatArray, q_ref: FloatArray) -> Any:
        """``solve(T, q_ref)``: the answer for ``T`` alone (``q_ref`` is not sent: the service
        takes poses only); the exception the handler raised is raised."""
        (answer,) = self.batch([T])
        if isinstance(answer, BaseException):
            raise answer
        return answer

    def take_notes(self) -> list[str]:
        """What Python 2 semantics changed since the last call (:class:`~kr210_sim.exercise.
        py2.Notes`), and the compatibility the libraries needed (:mod:`~kr210_sim.exercise.
        legacy`)."""
        return self.notes.take() + legacy.take_notes()


def _default_roots(folder: Path) -> list[Path]:
    roots = [folder]
    src = folder.parent / "src"
    if src.is_dir():
        roots.append(src.resolve())
    return roots
