"""The original exercise's form: a ROS service ``IK_server.py`` (Python 2, sympy, tf), run as it
was written.

* :mod:`~kr210_sim.exercise.form` tells the form apart and finds the server in a repository;
* :mod:`~kr210_sim.exercise.py2` reads Python 2 source as Python 2 did and compiles it;
* :mod:`~kr210_sim.exercise.server` runs the script as ``__main__`` with the ROS modules it
  imports (``shims/``: rospy, tf, tf2_ros, kuka_arm.srv and the message packages, backed by
  :mod:`~kr210_sim.exercise.node`, :mod:`~kr210_sim.exercise.messages` and
  :mod:`~kr210_sim.exercise.tf_transformations`) and serves its handler requests of many
  poses, as MoveIt sent them.

May import :mod:`kr210_sim.errors` and :mod:`kr210_sim.robot` only (the sandbox serves a server
through it). Until 0.2.0 this room was ``kr210_sim.robot.ros`` (the old path still works, with a
DeprecationWarning, until 0.3.0).
"""

from __future__ import annotations

from kr210_sim.exercise.form import HANDLER, find_server, is_ros_form, resolve_spec

__all__ = ["HANDLER", "find_server", "is_ros_form", "resolve_spec"]
