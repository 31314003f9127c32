"""The KR210 part of the cell's MJCF: what MuJoCo's URDF import cannot say.

Classes (Menagerie's split: ``visual`` meshes in group 2 never collide; ``collision``
primitives and ``hull`` colliders in group 3), gravity compensation, armature, damping, the
coupled fingers and their drive, the arm's position servos, sites and the gripper camera, and the
contact filter (:data:`TARGET_BIT` ... :data:`HULL_BIT`). :mod:`kr210_sim.cell.mjcf` calls these
while it builds the cell; only the build commands import either module.

Colliders: the URDF's primitives (boxes and cylinders; the finger pads and lips carry the
grasp), and per link one convex hull per finish of its visual mesh, from
:func:`kr210_sim.robot.meshes.collider_points` (a few dozen vertices each, written into the MJCF:
1,224 in all against 3,280 for hulls of the drawn meshes), each enclosing its visual parts and
standing at most about 7 mm proud of them.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import SceneError
from kr210_sim.robot.description import ARM_JOINTS, ARM_LINKS, FINGER_JOINTS
from kr210_sim.robot.meshes import DRAW_PREFIX, MAIN_FINISH, collider_points

import mujoco  # isort: skip  (after kr210_sim so MUJOCO_GL is chosen first)

#: Servo bandwidth of the arm joints in [Hz].
SERVO_HZ = 8.0
#: Reflected motor inertia added to each arm joint in [kg m^2].
ARMATURE = (8.0, 8.0, 4.0, 0.8, 0.8, 0.4)
#: Viscous joint damping of each arm joint in [N m s/rad].
JOINT_DAMPING = (5.0, 5.0, 3.0, 0.5, 0.5, 0.2)
#: Largest squeeze force of each finger in [N] (the tendon actuator's limit is twice this).
GRIP_FORCE = 40.0
#: Finger servo stiffness in [N/m] and damping in [N s/m] (on the tendon, whose force splits
#: half to each finger); the damping limits the closing speed to about
#: 2 GRIP_FORCE / FINGER_KV = 0.2 m/s, the URDF finger velocity limit.
FINGER_KP = 8000.0
FINGER_KV = 400.0
#: Contact parameters of fingers and targets (friction grasp).
GRASP_SOLREF = (0.004, 1.0)
GRASP_SOLIMP = (0.95, 0.99, 0.001, 0.5, 2.0)
FINGER_FRICTION = (1.5, 0.01, 0.0001)
#: Friction of the fingertip lips' acetal faces on the steel cylinder: sliding, torsional [m],
#: rolling [m]. Polyacetal against steel: static 0.1-0.3 (Shackelford, *CRC Materials Science and
#: Engineering Handbook*, 2001, "coefficients of static friction for polymers"); the upper end.
#: The lips' contact priority (:data:`LIP_PRIORITY`) is above the targets', so this coefficient
#: applies at the lips (the pads keep the target's). A lip touches the cylinder at its inner
#: corner, where the surface normal leans ``acos(1 - lip_depth / radius)`` off the squeeze axis
#: (50 deg for the 18 mm lip on the 50 mm cylinder, 33 deg for the 8 mm lip it replaced). When
#: the lip's friction angle, ``atan(mu)``, is larger, the lip wedges the cylinder: pulled
#: outward, it pushes the fingers apart until the lips alone carry the squeeze and the pads lose
#: it (the 8 mm lip at the target's 1.0, 45 deg, on MuJoCo 4.0.1: creep 3.5-5.8 mm a carry). At
#: 0.3 (17 deg) no lip can wedge a cylinder of the randomised range (0.04-0.06 m: 46-57 deg).
LIP_FRICTION = (0.3, 0.01, 0.0001)
#: Contact priority of the lips: above the targets' (1), so :data:`LIP_FRICTION` applies.
LIP_PRIORITY = 2


#: Contact filter bits (``contype``/``conaffinity``): a pair is tested when one's contype meets
#: the other's conaffinity. Targets touch targets, the cell and the robot's primitives; the
#: robot's primitives touch each other (non-adjacent links, less :data:`_EXCLUDES`), the targets
#: and the cell; its hulls touch only the cell's parts (not the floor: the primitives do); the
#: cell's parts never each other (they are static).
TARGET_BIT = 1
CELL_BIT = 2
ROBOT_BIT = 4
HULL_BIT = 8
#: conaffinity of the shelf, bin and obstacles, and of the floor.
CELL_AFFINITY = TARGET_BIT | ROBOT_BIT | HULL_BIT
FLOOR_AFFINITY = TARGET_BIT | ROBOT_BIT
#: conaffinity of a target.
TARGET_AFFINITY = TARGET_BIT | CELL_BIT | ROBOT_BIT
#: Links with robot colliders (primitives and hulls), base first.
ROBOT_LINKS = (*ARM_LINKS, *(j.replace("_joint", "_link") for j in FINGER_JOINTS))

#: Pairs of robot bodies that must never be checked for contact (beyond parent/child).
_EXCLUDES = (
    ("base_link", "link_2"),
    ("link_1", "link_3"),
    ("link_3", "link_5"),
    ("link_4", "link_6"),
    ("link_4", "gripper_link"),
    ("link_5", "gripper_link"),
    ("link_5", "right_gripper_finger_link"),
    ("link_5", "left_gripper_finger_link"),
    ("link_6", "right_gripper_finger_link"),
    ("link_6", "left_gripper_finger_link"),
    ("right_gripper_finger_link", "left_gripper_finger_link"),
)


def look_at(pos: npt.ArrayLike, target: npt.ArrayLike) -> tuple[float, ...]:
    """Camera ``xyaxes`` for a camera at ``pos`` [m] looking at ``target`` [m], z up."""
    p, t = np.asarray(pos, float), np.asarray(target, float)
    fwd = (t - p) / np.linalg.norm(t - p)
    right = np.cross(fwd, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    return (*right.round(6).tolist(), *up.round(6).tolist())


def add_hulls(spec: mujoco.MjSpec, hull: mujoco.MjsDefault, fine: bool = False) -> None:
    """One hull collider per finish of each link's visual mesh (``<link>_hull`` for the main
    finish, ``<link>_hull_<finish>`` for the others), its points written into the MJCF as a
    mesh asset of the same name; with ``fine``, the drawn mesh itself (MuJoCo collides with its
    convex hull: the tightest convex collider, with about 2.7 times the hull vertices).

    Hulls are in class ``hull`` (contype :data:`HULL_BIT`, conaffinity 0): they touch only the
    cell's parts, never the targets, the other links or the primitive colliders, so the grasp's
    contacts stay those of the fingers' pads and lips. Call after the dressing (it adds the
    finishes' meshes).
    """
    for link in ROBOT_LINKS:
        body = spec.body(link)
        for finish, points in collider_points(link).items():
            name = f"{link}_hull" if finish == MAIN_FINISH[link] else f"{link}_hull_{finish}"
            if fine:
                mesh = link if finish == MAIN_FINISH[link] else f"{link}__{finish}"
            else:
                mesh = name
                spec.add_mesh(name=name, uservert=np.round(points, 6).ravel().tolist())
            h = body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=mesh)
            h.classname = hull
            h.contype, h.conaffinity, h.group, h.density = HULL_BIT, 0, 3, 0.0


#: Suffix of the ``draw`` level's mesh assets (see :func:`add_draw_meshes`).
DRAW_SUFFIX = "_draw"


def add_draw_meshes(spec: mujoco.MjSpec) -> None:
    """A mesh asset ``<mesh>_draw`` (file ``draw_<file>``) beside each of the robot's drawn mesh
    assets: the ``draw`` level of detail, which no geom uses; the video renderer points the
    robot's visual geoms at it (:func:`kr210_sim.media.render.draw_level`), the physics never
    sees it. Call after the dressing has added the finishes' meshes."""
    links = tuple(MAIN_FINISH)
    for mesh in list(spec.meshes):
        stem = mesh.file.rsplit(".", 1)[0]
        if mesh.file and stem.split("__", 1)[0] in links:
            spec.add_mesh(name=mesh.name + DRAW_SUFFIX, file=DRAW_PREFIX + mesh.file)


def configure_robot(
    spec: mujoco.MjSpec,
    visual: mujoco.MjsDefault,
    collision: mujoco.MjsDefault,
) -> None:
    """Classes, gravity compensation, armature, damping, sites and camera for the URDF robot."""
    for body_name in (*ARM_LINKS[1:], *(j.replace("_joint", "_link") for j in FINGER_JOINTS)):
        body = spec.body(body_name)
        if body is None:
            raise SceneError(f"URDF import lost body {body_name!r}; check the compiler block")
        body.gravcomp = 1.0
    for body_name in (*ARM_LINKS, *(j.replace("_joint", "_link") for j in FINGER_JOINTS)):
        body = spec.body(body_name)
        for i, geom in enumerate(list(body.geoms)):
            if geom.contype == 0:  # URDF <visual>: the importer already made it non-colliding
                geom.classname = visual
                geom.contype, geom.conaffinity, geom.group = 0, 0, 2
                geom.name = f"{body_name}_visual" if i == 0 else f"{body_name}_visual{i}"
            else:
                geom.classname = collision
                geom.contype, geom.conaffinity, geom.group = ROBOT_BIT, ROBOT_BIT, 3
                geom.name = f"{body_name}_collision{i}"
    for name, armature, damping in zip(ARM_JOINTS, ARMATURE, JOINT_DAMPING, strict=True):
        joint = spec.joint(name)
        joint.armature = armature
        joint.damping = [damping, 0.0, 0.0]
        joint.actgravcomp = True
    for name in FINGER_JOINTS:
        joint = spec.joint(name)
        joint.armature = 0.01
        joint.damping = [1.0, 0.0, 0.0]
        joint.actgravcomp = True
    for finger in ("right_gripper_finger_link", "left_gripper_finger_link"):
        boxes = [
            g
            for g in spec.body(finger).geoms
            if g.type == mujoco.mjtGeom.mjGEOM_BOX and g.contype != 0
        ]
        if len(boxes) != 2:
            raise SceneError(f"{finger} needs two collision boxes (pad, lip), found {len(boxes)}")
        for geom, part in zip(boxes, ("pad", "lip"), strict=True):
            geom.name = f"{finger.split('_')[0]}_finger_{part}"
            geom.condim = 4
            geom.friction = list(FINGER_FRICTION if part == "pad" else LIP_FRICTION)
            geom.solref = list(GRASP_SOLREF)
            geom.solimp = list(GRASP_SOLIMP)
            if part == "lip":
                geom.priority = LIP_PRIORITY
    gripper = spec.body("gripper_link")
    gripper.add_site(name="tcp", pos=[0, 0, 0], size=[0.01, 0, 0], rgba=[1, 0, 0, 0.5], group=4)
    gripper.add_site(
        name="gripper", pos=[0.15, 0, 0], size=[0.01, 0, 0], rgba=[0, 1, 0, 0.5], group=4
    )
    gripper.add_camera(
        name="gripper",
        pos=[-0.08, 0.0, 0.16],
        xyaxes=list(look_at([-0.08, 0.0, 0.16], [0.35, 0.0, 0.0])),
        fovy=70,
    )
    for a, b in _EXCLUDES:
        spec.add_exclude(bodyname1=a, bodyname2=b)
    spec.add_equality(
        type=mujoco.mjtEq.mjEQ_JOINT,
        name="finger_coupling",
        name1=FINGER_JOINTS[1],
        name2=FINGER_JOINTS[0],
        data=[0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        solref=[0.005, 1.0],
    )


def add_actuators(spec: mujoco.MjSpec, inertia: npt.NDArray[np.float64]) -> None:
    """Position servos for the arm (gains from ``inertia`` [kg m^2]) and one for the fingers."""
    omega = 2.0 * math.pi * SERVO_HZ
    for name, inertia_i in zip(ARM_JOINTS, inertia, strict=True):
        kp = float(inertia_i * omega**2)
        kv = float(2.0 * inertia_i * omega)
        effort = spec.joint(name).actfrcrange[1]
        act = spec.add_actuator(
            name=name,
            target=name,
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE,
            forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
            forcerange=[-effort, effort],
        )
        act.gainprm[0] = kp
        act.biasprm[1] = -kp
        act.biasprm[2] = -kv
    # One actuator on a fixed tendon (the mean of the two finger joints): its force splits
    # equally between the fingers, so they close symmetrically (an actuator on one finger with
    # the other dragged along by the equality pushes the target sideways before the second
    # finger arrives).
    fingers = spec.add_tendon(name="fingers")
    for name in FINGER_JOINTS:
        fingers.wrap_joint(name, 0.5)
    lo, hi = spec.joint(FINGER_JOINTS[0]).range
    grip = spec.add_actuator(
        name="gripper",
        target="fingers",
        trntype=mujoco.mjtTrn.mjTRN_TENDON,
        gaintype=mujoco.mjtGain.mjGAIN_FIXED,
        biastype=mujoco.mjtBias.mjBIAS_AFFINE,
        forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
        forcerange=[-2.0 * GRIP_FORCE, 2.0 * GRIP_FORCE],
        ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE,
        ctrlrange=[lo, hi],
    )
    grip.gainprm[0] = FINGER_KP
    grip.biasprm[1] = -FINGER_KP
    grip.biasprm[2] = -FINGER_KV
