"""The control loop: the only code (with the runner's spawning) that steps and mutates MjData.

Every physics tick the loop samples the joint trajectory at the simulated time, drives the arm's
position servos with velocity and acceleration feed-forward, holds the gripper command, steps
MuJoCo, and records what the monitors need into preallocated buffers (cheap per tick; the
statistics are computed per segment with numpy).

Servo law (one MuJoCo actuator per joint, affine bias)::

    tau = kp (u - q) - kv qd,   with   u = q_des + (kv qd_des + I qdd_des) / kp

so that ``tau = kp (q_des - q) + kv (qd_des - qd) + I qdd_des``, with ``I`` the joint's current
mass-matrix diagonal (including armature): a PD servo plus velocity and inertia feed-forward.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import numpy.typing as npt

from kr210_sim.config import CellConfig
from kr210_sim.scene import CellHandles

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]


class JointTrajectory(Protocol):
    """What the control loop needs of a trajectory (see :mod:`kr210_sim.trajectory`)."""

    @property
    def duration(self) -> float: ...

    def sample(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]: ...


@dataclass(frozen=True, slots=True)
class _Hold:
    """A trajectory that holds one joint state (zero velocity) for ``duration`` [s]."""

    q: FloatArray
    duration: float

    def sample(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        z = np.zeros_like(self.q)
        return self.q, z, z


def hold(q: npt.ArrayLike, duration: float) -> JointTrajectory:
    """A trajectory that keeps the arm at ``q`` [rad] for ``duration`` [s]."""
    return _Hold(np.asarray(q, dtype=np.float64).copy(), float(duration))


#: Called after every physics step with the cell (read only): used by the video recorder.
StepHook = Callable[["Cell"], None]


@dataclass
class Recording:
    """Per-tick samples of one cycle, appended segment by segment.

    Attributes:
        t: Simulated time of each sample [s].
        q_des: Commanded joint positions [rad], (n, 6).
        qd_des: Commanded joint velocities [rad/s], (n, 6).
        q: Measured joint positions [rad], (n, 6).
        qd: Measured joint velocities [rad/s], (n, 6).
        target_in_gripper: Target centre in the gripper_link frame [m], (n, 3).
        env_contact: Robot-shelf/bin contact flag per tick.
        phase: Phase name per segment: list of (start index, name).
    """

    t: list[float] = field(default_factory=list)
    q_des: list[FloatArray] = field(default_factory=list)
    qd_des: list[FloatArray] = field(default_factory=list)
    q: list[FloatArray] = field(default_factory=list)
    qd: list[FloatArray] = field(default_factory=list)
    target_in_gripper: list[FloatArray] = field(default_factory=list)
    env_contact: list[bool] = field(default_factory=list)
    phase: list[tuple[int, str]] = field(default_factory=list)
    contact_pairs: set[tuple[str, str]] = field(default_factory=set)

    def arrays(self) -> dict[str, FloatArray]:
        """The samples as numpy arrays keyed by field name."""
        return {
            "t": np.asarray(self.t),
            "q_des": np.asarray(self.q_des).reshape(-1, 6),
            "qd_des": np.asarray(self.qd_des).reshape(-1, 6),
            "q": np.asarray(self.q).reshape(-1, 6),
            "qd": np.asarray(self.qd).reshape(-1, 6),
            "target_in_gripper": np.asarray(self.target_in_gripper).reshape(-1, 3),
            "env_contact": np.asarray(self.env_contact, dtype=bool),
        }


class Cell:
    """The simulated cell: model, data, handles and the servo gains read from the model.

    Args:
        model: The compiled cell model (see :func:`kr210_sim.scene.load_model`).
        config: The cell layout the model was built from.
    """

    def __init__(self, model: mujoco.MjModel, config: CellConfig | None = None) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.config = config or CellConfig()
        self.handles = CellHandles.from_model(model)
        h = self.handles
        self.kp = model.actuator_gainprm[h.arm_act, 0].copy()
        self.kv = -model.actuator_biasprm[h.arm_act, 2].copy()
        self._finger_dof = int(
            model.jnt_dofadr[
                mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "right_gripper_finger_joint")
            ]
        )
        self._m_diag = (model.M_rowadr + model.M_rownnz - 1)[h.arm_dof]
        self._is_robot = np.zeros(model.ngeom, dtype=bool)
        self._is_robot[list(h.robot_geoms)] = True
        self._is_env = np.zeros(model.ngeom, dtype=bool)
        self._is_env[list(h.shelf_geoms | h.bin_geoms)] = True
        self.active_target = 0
        self.grip_ctrl = float(model.actuator_ctrlrange[h.grip_act, 0])
        self.hooks: list[StepHook] = []
        self.phase = "idle"
        self.reset()

    # -- state ---------------------------------------------------------------------------
    def reset(self, q: npt.ArrayLike | None = None) -> None:
        """Reset to the ``home`` keyframe, optionally with the arm at ``q`` [rad], gripper open."""
        mujoco.mj_resetDataKeyframe(self.model, self.data, 0)
        if q is not None:
            self.data.qpos[self.handles.arm_qpos] = np.asarray(q, dtype=np.float64)
        self.grip_ctrl = float(self.model.actuator_ctrlrange[self.handles.grip_act, 0])
        self.data.qpos[self.handles.finger_qpos] = self.grip_ctrl
        self._command(self.q, np.zeros(6), np.zeros(6))
        self.data.ctrl[self.handles.grip_act] = self.grip_ctrl
        mujoco.mj_forward(self.model, self.data)

    @property
    def time(self) -> float:
        """Simulated time [s]."""
        return float(self.data.time)

    @property
    def q(self) -> FloatArray:
        """Measured arm joint positions [rad] (a copy)."""
        return self.data.qpos[self.handles.arm_qpos].copy()

    @property
    def finger_q(self) -> float:
        """Right finger joint position [m] (the left one is coupled to it)."""
        return float(self.data.qpos[self.handles.finger_qpos[0]])

    @property
    def finger_qd(self) -> float:
        """Right finger joint velocity [m/s]."""
        return float(self.data.qvel[self._finger_dof])

    def gripper_pose(self) -> FloatArray:
        """Measured pose of gripper_link in the world (= base) frame, 4x4."""
        b = self.handles.gripper_body
        T = np.eye(4)
        T[:3, :3] = self.data.xmat[b].reshape(3, 3)
        T[:3, 3] = self.data.xpos[b]
        return T

    def target_pose(self, index: int | None = None) -> tuple[FloatArray, FloatArray]:
        """Position [m] and rotation matrix of target ``index`` (default: the active one)."""
        b = self.handles.target_bodies[self.active_target if index is None else index]
        return self.data.xpos[b].copy(), self.data.xmat[b].reshape(3, 3).copy()

    def target_speed(self, index: int | None = None) -> float:
        """Linear speed of target ``index`` (default: the active one) in [m/s]."""
        dof = self.handles.target_dof[self.active_target if index is None else index]
        return float(np.linalg.norm(self.data.qvel[dof : dof + 3]))

    def target_in_gripper(self) -> FloatArray:
        """Centre of the active target in the gripper_link frame [m]."""
        b = self.handles.gripper_body
        R = self.data.xmat[b].reshape(3, 3)
        p_t = self.data.xpos[self.handles.target_bodies[self.active_target]]
        return R.T @ (p_t - self.data.xpos[b])

    def finger_target_contacts(self) -> tuple[bool, bool]:
        """Whether the right and left finger pads touch the active target."""
        g_t = int(self.handles.target_geoms[self.active_target])
        right, left = self.handles.finger_geoms
        hit_r = hit_l = False
        n = self.data.ncon
        if n:
            geoms = self.data.contact.geom[:n]
            for g1, g2 in geoms:
                pair = {int(g1), int(g2)}
                if g_t in pair:
                    hit_r |= right in pair
                    hit_l |= left in pair
        return hit_r, hit_l

    def env_contact_pairs(self) -> list[tuple[str, str]]:
        """Names of the robot/shelf-or-bin geom pairs in contact now."""
        n = self.data.ncon
        if not n:
            return []
        g = self.data.contact.geom[:n]
        hit = (self._is_robot[g[:, 0]] & self._is_env[g[:, 1]]) | (
            self._is_env[g[:, 0]] & self._is_robot[g[:, 1]]
        )
        return [(self.model.geom(int(a)).name, self.model.geom(int(b)).name) for a, b in g[hit]]

    # -- actuation -----------------------------------------------------------------------
    def _command(self, q: FloatArray, qd: FloatArray, qdd: FloatArray) -> None:
        inertia = self.data.M[self._m_diag]
        self.data.ctrl[self.handles.arm_act] = q + (self.kv * qd + inertia * qdd) / self.kp

    def set_gripper(self, ctrl: float) -> None:
        """Set the finger servo target [m] (finger joint position; low = open)."""
        lo, hi = self.model.actuator_ctrlrange[self.handles.grip_act]
        self.grip_ctrl = float(np.clip(ctrl, lo, hi))

    def open_gripper(self) -> None:
        """Command the fingers fully open."""
        self.set_gripper(float(self.model.actuator_ctrlrange[self.handles.grip_act, 0]))

    def close_gripper(self) -> None:
        """Command the fingers fully closed (the force range caps the grip force)."""
        self.set_gripper(float(self.model.actuator_ctrlrange[self.handles.grip_act, 1]))

    def track(
        self,
        traj: JointTrajectory,
        recording: Recording | None = None,
        phase: str = "",
        until: Callable[[Cell], bool] | None = None,
        extra_time: float = 0.0,
    ) -> float:
        """Follow ``traj`` from the current time, one physics step per control tick.

        Args:
            traj: The joint trajectory; its time 0 is now.
            recording: Where to append per-tick samples (None: record nothing).
            phase: Phase name for the recording and the video overlay.
            until: Optional predicate checked after every step; tracking stops when it is true.
            extra_time: Time to keep holding the final state after the trajectory ends [s].

        Returns:
            The time tracked in [s].
        """
        m, d, h = self.model, self.data, self.handles
        self.phase = phase
        dt = m.opt.timestep
        n_steps = int(np.ceil((traj.duration + extra_time) / dt - 1e-9))
        if recording is not None:
            recording.phase.append((len(recording.t), phase))
        grip_act = h.grip_act
        arm_qpos = h.arm_qpos
        arm_dof = h.arm_dof
        gb = h.gripper_body
        tb = h.target_bodies[self.active_target]
        is_robot, is_env = self._is_robot, self._is_env
        t0 = d.time
        steps = 0
        for k in range(1, n_steps + 1):
            q_des, qd_des, qdd_des = traj.sample(k * dt)
            self._command(q_des, qd_des, qdd_des)
            d.ctrl[grip_act] = self.grip_ctrl
            mujoco.mj_step(m, d)
            steps = k
            for hook in self.hooks:
                hook(self)
            if recording is not None:
                recording.t.append(d.time)
                recording.q_des.append(q_des)
                recording.qd_des.append(qd_des)
                recording.q.append(d.qpos[arm_qpos].copy())
                recording.qd.append(d.qvel[arm_dof].copy())
                # xpos/xmat are those of the step's start, for target and gripper alike.
                R = d.xmat[gb].reshape(3, 3)
                recording.target_in_gripper.append(R.T @ (d.xpos[tb] - d.xpos[gb]))
                hit = False
                if d.ncon:
                    g = d.contact.geom[: d.ncon]
                    hit = bool(
                        np.any(
                            (is_robot[g[:, 0]] & is_env[g[:, 1]])
                            | (is_env[g[:, 0]] & is_robot[g[:, 1]])
                        )
                    )
                    if hit:
                        recording.contact_pairs.update(self.env_contact_pairs())
                recording.env_contact.append(hit)
            if until is not None and until(self):
                break
        return float(d.time - t0) if steps else 0.0
