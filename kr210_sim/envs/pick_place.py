"""``kr210_sim/PickPlace-v0``: the cell as a goal-conditioned Gymnasium environment.

One episode is one pick-and-place cycle, set up as every episode is
(:func:`kr210_sim.sim.session.episode_runner`: a fresh runner, the arm at the ready pose, a
cylinder spawned by the runner's own sampler, :meth:`~kr210_sim.sim.runner.Runner.start_cycle`);
the policy moves the arm instead of the runner. The policy runs at 25 Hz: each step holds one
command for :data:`SUBSTEPS` = 20 physics steps of 2 ms (:data:`POLICY_DT` = 40 ms), tracked by
the same servo law as ``run`` (:meth:`kr210_sim.sim.cell.Cell.step_command`: ``Cell.track`` on
a constant-velocity command, velocity feed-forward included).

Observations (a ``Dict`` like Gymnasium-Robotics' Fetch tasks):

* ``observation`` (20,): joint positions [rad] (6), joint velocities [rad/s] (6), the finger
  gap [m] (1), gripper_link's position [m] (3) and orientation quaternion (w, x, y, z) (4).
* ``achieved_goal`` (3,): the cylinder's centre [m].
* ``desired_goal`` (3,): the centre of the bin's inside (between its floor and rim) [m]; the
  goal region is the bin's inside, :data:`GOAL_HALF_EXTENTS` around it, so that "the achieved
  goal is in the region" is exactly :func:`kr210_sim.score.scoring.in_bin`.

Actions in ``Box(-1, 1)``:

* ``control="joint"`` (7,): joint velocities as fractions of each joint's URDF velocity limit,
  integrated into the servo targets (clipped to the position limits), and the gripper.
* ``control="cartesian"`` (5,): gripper_link translation velocity in the world frame as a
  fraction of :data:`MAX_SPEED`, yaw rate as a fraction of :data:`MAX_YAW_RATE` (the gripper
  stays level), solved by our closed-form IK from the previous command (a pose out of reach
  holds the command; a step faster than a joint's velocity limit is shortened), and the gripper.
* The gripper entry sets the finger servo target: -1 fully open, +1 fully closed (the grip
  force is capped by the actuator, as in ``run``).

An action with NaN or infinite entries, of the wrong shape or outside [-1, 1] raises
:class:`~kr210_sim.errors.ActionError` before anything reaches MuJoCo.

Success (``info["is_success"]``) is decided by the runner's scoring
(:func:`kr210_sim.score.scoring.episode_success`, the rule :func:`~kr210_sim.score.scoring.score`
applies to a cycle): no robot contact with the cell during the episode (counted every physics
tick, ``info["robot_cell_contacts"]``), the fingers off the cylinder, and the cylinder in the bin
for good (:func:`~kr210_sim.score.scoring.contained`: its centre inside the walls and below the
rim, and its kinetic energy could not lift it to the rim; ``info["lift"]`` is that height [m]).
``info["rested_for"]`` says how long it has been still (:func:`~kr210_sim.score.scoring.is_still`,
counted every physics tick as ``run`` counts it). Reward:
``"sparse"`` (default) -1 per step until success, 0 then; ``"dense"`` minus the distance from the
cylinder to the goal and half the distance from the gripper to the cylinder, 0 on success.
Episodes terminate on success and are truncated after ``max_steps`` steps.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import numpy.typing as npt
from gymnasium import spaces

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import model_at, model_for
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.envs.sensor_obs import OBS_MODES, SensorObservations
from kr210_sim.errors import ActionError, ConfigError, UnreachablePoseError
from kr210_sim.plan.collide import CollisionChecker
from kr210_sim.plan.poses import gripper_pose
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.score.result import TargetSample
from kr210_sim.score.scoring import RestCounter, bin_region, episode_success, rise
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.sim.session import episode_runner

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]

#: Policy period [s]: 25 Hz.
POLICY_DT = 0.04
#: Physics steps per policy step (the cell's timestep is 2 ms).
SUBSTEPS = 20
#: Largest gripper translation speed of the cartesian mode, per axis [m/s].
MAX_SPEED = 1.5
#: Largest gripper yaw rate of the cartesian mode [rad/s].
MAX_YAW_RATE = 2.0
#: Default step limit: 12 s of simulated time.
MAX_STEPS = 300
#: Control modes and their action sizes.
CONTROLS = {"joint": 7, "cartesian": 5}
REWARDS = ("sparse", "dense")
#: Keys ``reset(options=...)`` takes.
RESET_OPTIONS = ("slot", "randomize")


def _quat(R: FloatArray) -> FloatArray:
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R).reshape(9))
    return q


def _yaw(R: FloatArray) -> float:
    return math.atan2(R[1, 0], R[0, 0])


def _info_values(info: Any, key: str) -> npt.NDArray[Any]:
    """``info[key]`` for one info dict, a dict of arrays (vector envs) or a sequence of dicts."""
    try:
        if isinstance(info, Mapping):
            return np.asarray(info[key])
        return np.asarray([i[key] for i in info])
    except (KeyError, TypeError):
        raise ConfigError(
            f"compute_reward needs the info the environment's step returns (with {key!r})"
        ) from None


class PickPlaceEnv(gym.Env[dict[str, Any], npt.NDArray[np.float32]]):
    """The KR210 cell as a goal-conditioned environment (see the module docstring).

    Args:
        control: ``"joint"`` or ``"cartesian"``.
        reward: ``"sparse"`` or ``"dense"``.
        max_steps: Steps before the episode is truncated.
        slot: Slot 1-9 for every episode, or 0 for a random slot per episode (as ``run``).
        randomize: Randomise the cylinder (pose, size, mass, friction) as ``run --randomize``.
        render_mode: None or ``"rgb_array"``.
        camera: Named camera for rendering (``overview``, ``shelf``, ``bin``, ``gripper``).
        width: Frame width [px].
        height: Frame height [px].
        scene: Another cell: an MJCF scene or a cell file (``.toml``, compiled); None for the
            committed scene.
        cell: A cell file (TOML) to compile instead of a scene, as ``run(cell=)`` and
            ``--cell`` take it; not with ``scene``.
        obs_mode: ``"state"``, or ManiSkill3's ``"rgbd"`` or ``"pointcloud"``: the cell's
            sensors seen too, their parameters in ``info["sensor_param"]``
            (:mod:`kr210_sim.envs.sensor_obs`).

    Raises:
        ConfigError: A bad argument (one sentence naming the choices).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": round(1.0 / POLICY_DT)}  # noqa: RUF012

    def __init__(
        self,
        control: str = "joint",
        reward: str = "sparse",
        max_steps: int = MAX_STEPS,
        slot: int = 0,
        randomize: bool = False,
        render_mode: str | None = None,
        camera: str = "overview",
        width: int = 480,
        height: int = 352,
        scene: str | Path | None = None,
        cell: str | Path | None = None,
        obs_mode: str = "state",
    ) -> None:
        if obs_mode not in OBS_MODES:
            raise ConfigError(f"obs_mode must be one of {', '.join(OBS_MODES)}, got {obs_mode!r}")
        if control not in CONTROLS:
            raise ConfigError(f"control must be 'joint' or 'cartesian', got {control!r}")
        if reward not in REWARDS:
            raise ConfigError(f"reward must be 'sparse' or 'dense', got {reward!r}")
        if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 1:
            raise ConfigError(f"max_steps must be a whole number >= 1, got {max_steps!r}")
        if render_mode not in (None, "rgb_array"):
            raise ConfigError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.control, self.reward_type, self.max_steps = control, reward, max_steps
        self.run_config = RunConfig(cycles=1, slot=slot, randomize=bool(randomize))
        self.render_mode = render_mode
        if scene is not None and cell is not None:
            raise ConfigError("give scene= or cell=, not both (a cell compiles to a scene)")
        self.model = model_for(None, Path(cell)) if cell is not None else model_at(scene)
        if render_mode is not None:  # checked here, not blamed on OpenGL at the first frame
            from kr210_sim.media.render import check_camera, check_frame_size

            check_camera(self.model, camera)
            check_frame_size(width, height)
        self.camera, self.width, self.height = camera, width, height
        self.obs_mode = obs_mode
        self._sensors = None if obs_mode == "state" else SensorObservations(self.model, obs_mode)
        self._renderer: mujoco.Renderer | None = None
        self._ended = False
        self.robot = load_robot()
        self.kinematics = Kinematics(self.robot)
        self.motion = MotionConfig()
        #: The cell as the compiled model holds it (slots, bin, drop spots): what ``run`` uses.
        self.layout = CellLayout.from_model(self.model)
        if not 0 <= self.run_config.slot <= self.layout.n_slots:
            raise ConfigError(
                f"slot must be 0 (random) or 1-{self.layout.n_slots}, got {self.run_config.slot!r}"
            )
        if round(POLICY_DT / self.model.opt.timestep) != SUBSTEPS:
            raise ConfigError(
                f"the scene's timestep is {self.model.opt.timestep} s; the environment needs "
                f"{POLICY_DT / SUBSTEPS} s ({SUBSTEPS} physics steps per policy step)"
            )
        #: The episode's runner (:func:`~kr210_sim.sim.session.episode_runner`, on this
        #: environment's model): its cell is :attr:`cell`, its planner is the expert's.
        #: One collision checker for every episode's runner (the model stays the same).
        self._checker = CollisionChecker(self.model, self.kinematics)
        self._seed = 0  # the last seed reset was given
        self.runner = self._runner(RunConfig(cycles=1), None)
        self.cell: Cell = self.runner.cell
        #: Where the arm waits and every episode starts: the runner's (the cell's own ready
        #: pose when it sets one, moved clear of the cell when it collides).
        self.ready_q = self.runner.planner.ready_q.copy()
        self.q_lower, self.q_upper = self.robot.q_lower.copy(), self.robot.q_upper.copy()
        self.qd_max = self.robot.qd_max.copy()
        lo, hi = self.model.actuator_ctrlrange[self.cell.handles.grip_act]
        self._grip_range = (float(lo), float(hi))
        b = self.layout.bin
        self.bin = b
        self.goal, self.goal_half_extents = bin_region(b)

        n = CONTROLS[control]
        self.action_space = spaces.Box(-1.0, 1.0, shape=(n,), dtype=np.float32)
        inf = np.inf
        self.observation_space = spaces.Dict(
            {
                "observation": spaces.Box(-inf, inf, shape=(20,), dtype=np.float64),
                "achieved_goal": spaces.Box(-inf, inf, shape=(3,), dtype=np.float64),
                "desired_goal": spaces.Box(-inf, inf, shape=(3,), dtype=np.float64),
                **(self._sensors.spaces() if self._sensors is not None else {}),
            }
        )
        #: Counts resets (a new episode); the scripted expert re-plans when it changes.
        self.episode = 0
        self.steps = 0
        self.target: TargetSample | None = None
        self.q_cmd = self.ready_q.copy()
        self.p_cmd = np.zeros(3)
        self.yaw_cmd = 0.0
        self.grip_cmd = -1.0
        self._rest = RestCounter(self.model.opt.timestep)
        self._contacts = 0
        self._mass = self.layout.target.mass
        self._sensor_param: dict[str, Any] = {}

    # -- Gymnasium API -----------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode: the arm at the ready pose, a fresh cylinder in a slot.

        With ``seed=s`` the cylinder is the one ``run --cycles 1 --seed s`` spawns (same slot
        draw, same sampler), given the same ``slot`` and ``randomize``, and the episode's runner
        (whose planner the scripted expert uses) plans as that run's does, seeded with ``s``;
        without a seed, with the last one given (0 before any).

        Args:
            seed: Seed of the episode's generator.
            options: ``{"slot": k}`` (0-9) and/or ``{"randomize": bool}`` for this episode.

        Raises:
            ConfigError: An unknown option or a slot outside 0-9.
        """
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = sorted(set(options) - set(RESET_OPTIONS))
        if unknown:
            raise ConfigError(f"unknown reset option(s) {unknown}: use 'slot' and 'randomize'")
        base = self.run_config
        slot = options.get("slot", base.slot)
        n = self.layout.n_slots
        if isinstance(slot, bool) or not isinstance(slot, (int, np.integer)) or not 0 <= slot <= n:
            raise ConfigError(f"slot must be 0 (random) or 1-{n}, got {slot!r}")
        if seed is not None:  # the runner plans with it as `run --seed` does (OMPL's seed)
            self._seed = int(seed)
        config = RunConfig(
            cycles=1,
            seed=self._seed,
            slot=int(slot),
            randomize=bool(options.get("randomize", base.randomize)),
        )
        self.runner = self._runner(config, self.np_random)
        self.cell = self.runner.cell
        self.target, _ = self.runner.start_cycle(1, self.runner.slot_for_cycle())
        self._mass = self.target.spec.mass
        self.q_cmd = self.ready_q.copy()
        T = self.kinematics.forward(self.q_cmd)
        self.p_cmd, self.yaw_cmd = T[:3, 3].copy(), _yaw(T[:3, :3])
        self.grip_cmd = -1.0
        self.steps, self._contacts, self._ended = 0, 0, False
        self._rest.reset()
        self.episode += 1
        return self._observation(), self._info()

    def step(
        self, action: npt.ArrayLike
    ) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        """Apply one action for :data:`POLICY_DT` (see the module docstring).

        Raises:
            ActionError: NaN or infinite entries, the wrong shape, or entries outside [-1, 1].
        """
        if self.target is None:
            raise ConfigError("call reset() before step()")
        if self._ended:
            raise ConfigError("the episode has ended (terminated or truncated): call reset()")
        a = self._check_action(action)
        q_next = self._joint_command(a) if self.control == "joint" else self._cartesian_command(a)
        lo, hi = self._grip_range
        self.grip_cmd = float(a[-1])
        self.cell.set_gripper(lo + (self.grip_cmd + 1.0) / 2.0 * (hi - lo))
        q_prev, self.q_cmd = self.q_cmd, q_next
        qd = (q_next - q_prev) / POLICY_DT

        d, h = self.cell.data, self.cell.handles
        qvel, dof = d.qvel, int(h.target_dof[self.cell.active_target])
        sensors = list(h.env_contact_sensors)

        def watch(c: Cell) -> bool:  # the runner's rest and contact counts, every physics tick
            vx, vy, vz, wx, wy, wz = qvel[dof : dof + 6].tolist()
            self._rest.update(math.hypot(vx, vy, vz), math.hypot(wx, wy, wz))
            self._contacts += bool(d.sensordata[sensors].any())
            return False

        self.cell.step_command(q_prev, qd, SUBSTEPS, until=watch)
        self.steps += 1
        obs, info = self._observation(), self._info()
        reward = float(self.compute_reward(obs["achieved_goal"], obs["desired_goal"], info))
        terminated = bool(info["is_success"])
        truncated = self.steps >= self.max_steps and not terminated
        self._ended = terminated or truncated
        return obs, reward, terminated, truncated, info

    def compute_reward(
        self, achieved_goal: npt.ArrayLike, desired_goal: npt.ArrayLike, info: Any
    ) -> npt.NDArray[np.float64] | float:
        """Reward of reaching ``achieved_goal`` for ``desired_goal``, vectorised over a batch.

        The goal counts as reached by the runner's rule
        (:func:`kr210_sim.score.scoring.episode_success`) with the goal region
        :data:`goal_half_extents` around the desired goal (for the bin, its inside): the achieved
        goal in the region for good (its kinetic energy could not lift it to the region's top,
        ``info["lift"]``), the fingers off it (``info["released"]``) and no robot-cell contact
        in the episode (``info["robot_cell_contacts"]``).

        Args:
            achieved_goal: Shape (3,) or (n, 3) [m].
            desired_goal: Shape (3,) or (n, 3) [m].
            info: The step's info, a dict of arrays, or a sequence of info dicts.

        Returns:
            Sparse: 0 where reached, else -1. Dense: 0 where reached, else minus the distance
            to the goal [m] and half the gripper's distance to the cylinder [m].
        """
        ag = np.asarray(achieved_goal, dtype=np.float64)
        dg = np.asarray(desired_goal, dtype=np.float64)
        reached = episode_success(
            ag,
            _info_values(info, "lift"),
            _info_values(info, "released"),
            _info_values(info, "robot_cell_contacts"),
            dg,
            self.goal_half_extents,
        )
        if self.reward_type == "sparse":
            r = np.where(reached, 0.0, -1.0)
        else:
            d = np.linalg.norm(ag - dg, axis=-1)
            r = np.where(reached, 0.0, -(d + 0.5 * _info_values(info, "gripper_to_target")))
        return float(r) if np.ndim(r) == 0 else r

    def render(self) -> npt.NDArray[np.uint8] | None:
        """An RGB frame (height, width, 3) from :attr:`camera`, or None without a render mode."""
        if self.render_mode is None:
            return None
        from kr210_sim.media.render import make_renderer, render_frame

        if self._renderer is None:
            self._renderer = make_renderer(self.model, self.width, self.height)
        return render_frame(self._renderer, self.cell.data, self.camera)

    def close(self) -> None:
        """Free the renderers."""
        if self._sensors is not None:
            self._sensors.close()
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # -- helpers -----------------------------------------------------------------------------
    def _runner(self, config: RunConfig, rng: np.random.Generator | None) -> Runner:
        """A fresh episode runner on this environment's model (the renderer draws it)."""
        return episode_runner(
            config.seed,
            slot=config.slot,
            randomize=config.randomize,
            model=self.model,
            copy_model=False,
            robot=self.robot,
            rng=rng,
            checker=self._checker,
        )

    def _check_action(self, action: npt.ArrayLike) -> FloatArray:
        if np.iscomplexobj(action) or isinstance(action, complex):
            raise ActionError(
                f"action must be {CONTROLS[self.control]} real numbers in [-1, 1], got complex "
                "numbers"
            )
        try:
            a = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            raise ActionError(
                f"action must be {CONTROLS[self.control]} numbers in [-1, 1], got "
                f"{type(action).__name__}"
            ) from None
        shape = self.action_space.shape
        if a.shape != shape:
            raise ActionError(
                f"action must have shape {shape} for control={self.control!r}, got {a.shape}"
            )
        bad = np.flatnonzero(~np.isfinite(a))
        if len(bad):
            raise ActionError(
                f"action entry {int(bad[0])} is {a[bad[0]]}: every entry must be a finite number "
                "in [-1, 1]"
            )
        out = np.flatnonzero(np.abs(a) > 1.0 + 1e-6)
        if len(out):
            raise ActionError(
                f"action entry {int(out[0])} is {a[out[0]]:.6g}, outside the action space "
                "[-1, 1]: clip it (numpy.clip(action, -1, 1))"
            )
        return np.clip(a, -1.0, 1.0)

    def _joint_command(self, a: FloatArray) -> FloatArray:
        """Servo targets after integrating the joint velocity command for one step [rad]."""
        q = self.q_cmd + a[:6] * self.qd_max * POLICY_DT
        return np.clip(q, self.q_lower, self.q_upper)

    def _cartesian_command(self, a: FloatArray) -> FloatArray:
        """Servo targets for the commanded gripper pose after one step [rad]."""
        p = self.p_cmd + a[:3] * MAX_SPEED * POLICY_DT
        yaw = self.yaw_cmd + a[3] * MAX_YAW_RATE * POLICY_DT
        try:
            q = self.kinematics.nearest(gripper_pose(p, yaw), self.q_cmd)
        except UnreachablePoseError:
            return self.q_cmd.copy()  # out of reach: hold the last command
        dq = q - self.q_cmd
        over = float(np.max(np.abs(dq) / (self.qd_max * POLICY_DT)))
        if over > 1.0:  # faster than a joint may move: go as far as the limits allow
            q = self.q_cmd + dq / over
            T = self.kinematics.forward(q)
            p, yaw = T[:3, 3].copy(), _yaw(T[:3, :3])
        self.p_cmd, self.yaw_cmd = p, float(yaw)
        return q

    def _observation(self) -> dict[str, Any]:
        """The observation (with a camera mode, the sensors' looks too; their parameters wait
        in :attr:`_sensor_param` for :meth:`_info`)."""
        seen: dict[str, Any] = {}
        if self._sensors is not None:
            seen = self._sensors.observe(self.cell.data)
            self._sensor_param = seen.pop("sensor_param")
        c = self.cell
        d = c.data
        h = c.handles
        T = c.gripper_pose()
        obs = np.concatenate(
            (
                d.qpos[h.arm_qpos],
                d.qvel[h.arm_dof],
                (self.robot.finger_gap(c.finger_q),),
                T[:3, 3],
                _quat(T[:3, :3]),
            )
        )
        return {
            "observation": obs.astype(np.float64),
            "achieved_goal": c.target_pose()[0],
            "desired_goal": self.goal.copy(),
            **seen,
        }

    def _info(self) -> dict[str, Any]:
        c = self.cell
        position = c.target_pose()[0]
        lift = float(rise(c.target_energy(), self._mass))
        released = not any(c.finger_target_contacts())
        success = episode_success(
            position, lift, released, self._contacts, self.goal, self.goal_half_extents
        )
        sensors = c.data.sensordata[list(c.handles.env_contact_sensors)]
        return {
            "is_success": bool(success),
            "lift": lift,
            "rested_for": self._rest.rested_for,
            "released": released,
            "gripper_to_target": float(np.linalg.norm(c.gripper_pose()[:3, 3] - position)),
            "robot_cell_contact": bool(sensors.any()),  # shelf, bin, obstacles, floor
            "robot_cell_contacts": self._contacts,  # ticks with one, this episode
            "slot": self.target.slot if self.target is not None else 0,
            "time": c.time,
            **({"sensor_param": self._sensor_param} if self._sensors is not None else {}),
        }
