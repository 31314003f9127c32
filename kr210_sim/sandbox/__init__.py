"""The sandbox: the jail, and the process that runs a user's code in it.

A user's IK (a plain Python function or the original exercise's ``IK_server.py``) never runs in
the grader's process. :mod:`~kr210_sim.sandbox.user_ik` names what to load
(:func:`~kr210_sim.sandbox.user_ik.load_ik`); :mod:`~kr210_sim.sandbox.ik_sandbox` starts it in a
child process (:mod:`~kr210_sim.sandbox.ik_child`) and talks to it over a pipe
(:mod:`~kr210_sim.sandbox.ik_wire`), with a budget per call; :mod:`~kr210_sim.sandbox.guarded`
loads the IK a command asks for, once per process; :mod:`~kr210_sim.sandbox.ik_guard` checks
every answer. A user's perception function runs the same way
(:mod:`~kr210_sim.sandbox.user_perception`, :mod:`~kr210_sim.sandbox.perception_sandbox`,
:mod:`~kr210_sim.sandbox.perception_child`). Where the child runs confined, the jail is built by
:mod:`~kr210_sim.sandbox.jail` from bubblewrap (:mod:`~kr210_sim.sandbox.bwrap`), a seccomp
filter (:mod:`~kr210_sim.sandbox.seccomp`), cgroup limits (:mod:`~kr210_sim.sandbox.cgroups`),
the in-child confinement (:mod:`~kr210_sim.sandbox.confine`) and ``/proc`` reading
(:mod:`~kr210_sim.sandbox.procfs`; the time a process was held off the CPU by others:
:mod:`~kr210_sim.sandbox.held`); of kr210_sim it shows only the harness
(:mod:`~kr210_sim.sandbox.harness`) and of the user only its own files, one by one
(:mod:`~kr210_sim.sandbox.jail_files`). :mod:`~kr210_sim.sandbox.captured` keeps the process's
output bounded.

May import: :mod:`kr210_sim.errors`, :mod:`kr210_sim.util`, :mod:`kr210_sim.robot` (the
kinematics an answer is checked against) and :mod:`kr210_sim.exercise` (to serve a ROS-form
server). Imported by the planner, the runner and the grader; it imports none of them.
"""

from __future__ import annotations

from kr210_sim.sandbox.ik_guard import CheckedIk, assess
from kr210_sim.sandbox.user_ik import UserIk, load_ik

__all__ = ["CheckedIk", "UserIk", "assess", "load_ik"]
