"""A scripted expert for :class:`~kr210_sim.envs.pick_place.PickPlaceEnv`: our planner, driven
through the environment's own action space.

At the first step of an episode the expert plans the cycle ``run`` executes, from the observed
cylinder (``achieved_goal``) and its size: the environment's runner's
:meth:`~kr210_sim.sim.runner.Runner.plan_cycle`, with the same collision checks, detours and drop
spot as ``run`` (:class:`kr210_sim.plan.cycle.CyclePlan`: approach, close, lift, retreat, carry
to the bin, open, return). Every step it turns the plan into an action:

* ``joint``: the joint velocity that brings the servo command to the plan's joint state one
  policy step ahead (the plan respects the velocity limits, so the action stays in [-1, 1]).
* ``cartesian``: the gripper velocity and yaw rate that bring the commanded pose to the plan's
  pose (forward kinematics of the plan) one step ahead. The plan's joint-space swings move the
  gripper faster than the action space allows, so the expert's clock advances only as far as
  the action can follow (found by bisection): the cartesian expert runs the same path, slower.

The gripper entry is -1 (open) or +1 (closed), switched by the plan's grip steps; the arm holds
for :data:`CLOSE_TIME` at the close and for the plan's wait at the release. The expert reads
the environment's command state and the cylinder's size (privileged information, as scripted
demonstrators in robosuite and ManiSkill do) and plans with its runner; it never touches the
simulation.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import numpy.typing as npt

from kr210_sim.envs.pick_place import MAX_SPEED, MAX_YAW_RATE, POLICY_DT, PickPlaceEnv
from kr210_sim.errors import ConfigError, PlanningError, UnreachablePoseError
from kr210_sim.plan.cycle import CyclePlan, Grip
from kr210_sim.sim.cell import JointTrajectory, hold

log = logging.getLogger(__name__)
FloatArray = npt.NDArray[np.float64]

#: How long the expert keeps the gripper closing before it lifts [s] (``run`` waits for the grip
#: to be confirmed, at most ``close_timeout``).
CLOSE_TIME = 0.5
#: Bisection steps of the cartesian expert's clock.
BISECTIONS = 12


@dataclass(frozen=True, slots=True)
class _Segment:
    """One part of the script: a joint trajectory from ``start`` [s] and the gripper command."""

    start: float
    trajectory: JointTrajectory
    grip: float

    @property
    def end(self) -> float:
        return self.start + self.trajectory.duration


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class ScriptedExpert:
    """``expert(obs) -> action`` for a :class:`PickPlaceEnv` (or a wrapper of one).

    Args:
        env: The environment the expert acts in (its ``unwrapped`` must be a
            :class:`PickPlaceEnv`).

    Raises:
        ConfigError: When ``env`` is not a PickPlace environment.
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        inner = env.unwrapped
        if not isinstance(inner, PickPlaceEnv):
            raise ConfigError(
                f"ScriptedExpert drives kr210_sim/PickPlace-v0, got {type(inner).__name__}"
            )
        self.env = inner
        #: The episode's cycle plan (None before the first step, or when none exists).
        self.plan: CyclePlan | None = None
        self._episode = -1
        self._script: list[_Segment] = []
        self._t = 0.0

    def __call__(self, obs: dict[str, FloatArray]) -> npt.NDArray[np.float32]:
        """The action for ``obs`` (the observation the environment just returned)."""
        e = self.env
        if e.episode != self._episode:
            self._episode = e.episode
            self._script = self._plan(np.asarray(obs["achieved_goal"], dtype=np.float64))
            self._t = 0.0
        grip = self._grip_at(self._t)
        if e.control == "joint":
            tau = self._t + POLICY_DT
            a = (self._q_at(tau) - e.q_cmd) / (e.qd_max * POLICY_DT)
            action = np.append(np.clip(a, -1.0, 1.0), grip)
        else:
            tau, move = self._cartesian_step()
            action = np.append(move, grip)
        self._t = tau
        return action.astype(np.float32)

    # -- the script ----------------------------------------------------------------------------
    def _plan(self, position: FloatArray) -> list[_Segment]:
        """The cycle plan's steps as segments from the ready pose; a hold with the gripper open
        when no plan exists (the episode then fails as ``run`` would score it: unreachable)."""
        e = self.env
        assert e.target is not None
        q0 = e.q_cmd.copy()
        self.plan = None
        try:
            plan = self.plan = e.runner.plan_cycle(position, e.target.spec, q0)
        except (UnreachablePoseError, PlanningError) as exc:
            log.info("episode %d: no plan: %s", e.episode, exc)
            return [_Segment(0.0, hold(q0, math.inf), -1.0)]
        script, t, q, grip = [], 0.0, q0, -1.0
        for step in plan.steps:
            traj: JointTrajectory
            if step.move is not None:
                traj, q = step.move.trajectory, step.move.q_end
            else:  # a grip: the gripper's command changes, the arm holds
                grip = 1.0 if step.grip is Grip.CLOSE else -1.0
                traj = hold(q, CLOSE_TIME if step.grip is Grip.CLOSE else step.wait)
            script.append(_Segment(t, traj, grip))
            t += traj.duration
        script.append(_Segment(t, hold(q, math.inf), grip))
        return script

    def _segment(self, t: float) -> _Segment:
        for seg in self._script:
            if t < seg.end:
                return seg
        return self._script[-1]

    def _q_at(self, t: float) -> FloatArray:
        seg = self._segment(t)
        return seg.trajectory.sample(t - seg.start)[0]

    def _grip_at(self, t: float) -> float:
        return self._segment(t).grip

    def _cartesian_step(self) -> tuple[float, FloatArray]:
        """The expert's clock after this step and the translation / yaw-rate part of the action."""
        e = self.env

        def need(t: float) -> tuple[float, FloatArray]:
            T = e.kinematics.forward(self._q_at(t))
            a = np.append(
                (T[:3, 3] - e.p_cmd) / (MAX_SPEED * POLICY_DT),
                _wrap(math.atan2(T[1, 0], T[0, 0]) - e.yaw_cmd) / (MAX_YAW_RATE * POLICY_DT),
            )
            return float(np.max(np.abs(a))), a

        lo, hi = self._t, self._t + POLICY_DT
        ratio, a = need(hi)
        if ratio <= 1.0:
            return hi, a
        ratio_lo, a_lo = need(lo)
        if ratio_lo > 1.0:  # behind the plan already: head for it at full speed
            return lo, a_lo / ratio_lo
        best = a_lo
        for _ in range(BISECTIONS):
            mid = 0.5 * (lo + hi)
            ratio, a = need(mid)
            if ratio <= 1.0:
                lo, best = mid, a
            else:
                hi = mid
        return lo, best
