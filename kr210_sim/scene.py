"""URDF -> MJCF: the KR210 and its pick-and-place cell as a MuJoCo model.

The robot comes from MuJoCo's own URDF import of ``assets/kr210/kr210.urdf``; this module adds
what URDF cannot say (actuators, gravity compensation, armature, the coupled fingers, sites,
cameras, contact parameters, a ``home`` keyframe) and the cell (floor, shelf, bin, targets,
lights). :func:`build_scene` writes the result to ``scenes/``; the runtime loads the committed
file with :func:`load_model`, and a test proves the committed file is current.

Choices (see also the README in ``assets/kr210``):

* Gravity is compensated on the arm bodies (``gravcomp=1``, routed through the actuators with
  ``actuatorgravcomp`` so it counts against the drive limits); the drive limits are the URDF
  ``effort`` values, which we raised to KR210-class kN m figures.
* Each arm joint has a position servo with ~8 Hz bandwidth: ``kp = I (2 pi f)^2`` and critical
  damping ``kv = 2 I (2 pi f)``, with ``I`` the joint's inertia (mass-matrix diagonal plus
  armature) at the home pose. The control loop adds velocity and acceleration feed-forward
  through the same actuator (see :mod:`kr210_sim.control`).
* Fingers are coupled by a joint equality and driven by one position actuator on the right
  finger whose force range caps the grip force.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from kr210_sim import dressing
from kr210_sim.config import CellConfig
from kr210_sim.errors import ConfigError, SceneError
from kr210_sim.outputs import check_folder, write_bytes_atomic
from kr210_sim.paths import MESH_DIR, SCENE_PATH, SCENES_DIR, URDF_PATH
from kr210_sim.robot import ARM_JOINTS, ARM_LINKS, FINGER_JOINTS

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
#: Friction of the bin floor (a rubber mat): sliding, torsional [m], rolling [m]. Its rolling
#: resistance (condim 6, and a higher priority than the targets', so its parameters apply: its
#: contact stiffness is therefore the targets' too, GRASP_SOLREF) lets a
#: cylinder that lands on its side come to rest instead of rolling wall to wall, and one that
#: lands upright stop rocking on its rim. Without it 2 of 300 randomised cycles ended still
#: rolling after 3 s; with 2 mm, 1 of 200 ten-cycle runs ended with a cylinder rocking.
BIN_FLOOR_FRICTION = (1.0, 0.01, 0.005)
#: Simulation timestep in [s].
TIMESTEP = 0.002
#: Offscreen framebuffer size in [px] (largest video frame).
OFFSCREEN_SIZE = (1920, 1088)

TARGET_RGBA = (0.1, 0.35, 0.95, 1.0)
SHELF_RGBA = (0.55, 0.42, 0.3, 1.0)
BIN_RGBA = (0.3, 0.32, 0.36, 1.0)

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


def target_name(index: int) -> str:
    """Body (and geom) name of target cylinder ``index`` (0-based)."""
    return f"target_{index}"


def _look_at(pos: npt.ArrayLike, target: npt.ArrayLike) -> tuple[float, ...]:
    """Camera ``xyaxes`` for a camera at ``pos`` [m] looking at ``target`` [m], z up."""
    p, t = np.asarray(pos, float), np.asarray(target, float)
    fwd = (t - p) / np.linalg.norm(t - p)
    right = np.cross(fwd, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    return (*right.round(6).tolist(), *up.round(6).tolist())


def _box(
    body: mujoco.MjsBody,
    name: str,
    center: npt.ArrayLike,
    half: npt.ArrayLike,
    rgba: tuple[float, ...],
    cls: mujoco.MjsDefault,
) -> mujoco.MjsGeom:
    geom = body.add_geom(
        name=name,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=[float(v) for v in np.asarray(center, dtype=float)],
        size=[float(v) for v in np.asarray(half, dtype=float)],
        rgba=list(rgba),
    )
    geom.classname = cls
    return geom


def _configure_robot(
    spec: mujoco.MjSpec, visual: mujoco.MjsDefault, collision: mujoco.MjsDefault
) -> None:
    """Classes, gravity compensation, armature, damping, sites and camera for the URDF robot."""
    for body_name in (*ARM_LINKS[1:], *(j.replace("_joint", "_link") for j in FINGER_JOINTS)):
        body = spec.body(body_name)
        if body is None:
            raise SceneError(f"URDF import lost body {body_name!r}; check the compiler block")
        body.gravcomp = 1.0
    for body_name in (*ARM_LINKS, *(j.replace("_joint", "_link") for j in FINGER_JOINTS)):
        body = spec.body(body_name)
        for i, geom in enumerate(body.geoms):
            if geom.contype == 0:  # URDF <visual>: the importer already made it non-colliding
                geom.classname = visual
                geom.contype, geom.conaffinity, geom.group = 0, 0, 2
                geom.name = f"{body_name}_visual" if i == 0 else f"{body_name}_visual{i}"
            else:
                geom.classname = collision
                geom.contype, geom.conaffinity, geom.group = 1, 1, 3
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
            geom.friction = list(FINGER_FRICTION)
            geom.solref = list(GRASP_SOLREF)
            geom.solimp = list(GRASP_SOLIMP)
    gripper = spec.body("gripper_link")
    gripper.add_site(name="tcp", pos=[0, 0, 0], size=[0.01, 0, 0], rgba=[1, 0, 0, 0.5], group=4)
    gripper.add_site(
        name="gripper", pos=[0.15, 0, 0], size=[0.01, 0, 0], rgba=[0, 1, 0, 0.5], group=4
    )
    gripper.add_camera(
        name="gripper",
        pos=[-0.08, 0.0, 0.16],
        xyaxes=list(_look_at([-0.08, 0.0, 0.16], [0.35, 0.0, 0.0])),
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


def _add_actuators(spec: mujoco.MjSpec, inertia: npt.NDArray[np.float64]) -> None:
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


def _add_world(spec: mujoco.MjSpec, cell: CellConfig, static: mujoco.MjsDefault) -> None:
    """Floor, sky, lights and the fixed cameras (the look: :mod:`kr210_sim.dressing`)."""
    world = spec.worldbody
    floor = world.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], material="floor"
    )
    floor.classname = static
    # The whole cell, from high enough to look over the bin cage's rim into it.
    overview_pos, overview_at = (-1.6, -2.2, 3.4), (1.35, 1.0, 0.95)
    world.add_camera(
        name="overview",
        pos=list(overview_pos),
        xyaxes=list(_look_at(overview_pos, overview_at)),
        fovy=56,
    )
    shelf_at = (cell.shelf.x_front + 0.1, 0.0, 1.6)
    shelf_pos = (0.5, -1.6, 2.3)
    world.add_camera(
        name="shelf", pos=list(shelf_pos), xyaxes=list(_look_at(shelf_pos, shelf_at)), fovy=62
    )
    bin_x, bin_y = cell.bin.center_xy
    # Steep enough (about 70 deg down) to see the bin's floor over its 1 m walls.
    bin_pos = (bin_x - 0.55, bin_y + 0.75, 3.3)
    world.add_camera(
        name="bin", pos=list(bin_pos), xyaxes=list(_look_at(bin_pos, (bin_x, bin_y, 0.1))), fovy=45
    )
    # Three-quarter view of the middle shelf bay: the wrist, the gripper and the grasp large.
    slot = cell.slot(5)
    hero_at = (slot[0] - 0.3, slot[1] + 0.05, slot[2] - 0.08)
    hero_pos = (slot[0] - 0.95, slot[1] - 1.0, slot[2] + 0.45)
    world.add_camera(
        name="hero", pos=list(hero_pos), xyaxes=list(_look_at(hero_pos, hero_at)), fovy=45
    )


def _add_shelf(spec: mujoco.MjSpec, cell: CellConfig, static: mujoco.MjsDefault) -> None:
    """Three boards, four dividers, two side walls, a back panel and a top."""
    s = cell.shelf
    body = spec.worldbody.add_body(name="shelf")
    cx, hx = s.x_front + s.depth / 2.0, s.depth / 2.0
    half_t = s.board_thickness / 2.0
    for row, top in enumerate(s.board_tops, start=1):
        _box(
            body,
            f"shelf_board_{row}",
            (cx, 0, top - half_t),
            (hx, s.half_width, half_t),
            SHELF_RGBA,
            static,
        )
    _box(
        body,
        "shelf_top",
        (cx, 0, s.height - half_t),
        (hx, s.half_width, half_t),
        SHELF_RGBA,
        static,
    )
    _box(
        body,
        "shelf_back",
        (s.x_front + s.depth - 0.01, 0, s.height / 2.0),
        (0.01, s.half_width, s.height / 2.0),
        SHELF_RGBA,
        static,
    )
    for side in (-1, 1):
        for kind, (inner, outer) in (("divider", s.divider_y), ("wall", s.post_y)):
            y = side * (inner + outer) / 2.0
            name = f"shelf_{kind}_{'left' if side > 0 else 'right'}"
            _box(
                body,
                name,
                (cx, y, s.height / 2.0),
                (hx, (outer - inner) / 2.0, s.height / 2.0),
                SHELF_RGBA,
                static,
            )


def _add_bin(spec: mujoco.MjSpec, cell: CellConfig, static: mujoco.MjsDefault) -> None:
    """The open drop bin: a floor slab and four walls."""
    b = cell.bin
    bx, by = b.center_xy
    half, w = b.outer_size / 2.0, b.wall
    body = spec.worldbody.add_body(name="bin")
    floor = _box(
        body,
        "bin_floor",
        (bx, by, b.floor_top / 2.0),
        (half, half, b.floor_top / 2.0),
        BIN_RGBA,
        static,
    )
    floor.condim = 6
    floor.friction = list(BIN_FLOOR_FRICTION)
    floor.priority = 2
    # Its priority makes its contact parameters the ones that apply against a target: as stiff
    # as the targets' own, or a cylinder dropped from 1.6 m sinks 31-33 mm into the floor.
    floor.solref = list(GRASP_SOLREF)
    floor.solimp = list(GRASP_SOLIMP)
    h = b.height / 2.0
    _box(body, "bin_wall_px", (bx + half - w / 2, by, h), (w / 2, half, h), BIN_RGBA, static)
    _box(body, "bin_wall_nx", (bx - half + w / 2, by, h), (w / 2, half, h), BIN_RGBA, static)
    _box(body, "bin_wall_py", (bx, by + half - w / 2, h), (half - w, w / 2, h), BIN_RGBA, static)
    _box(body, "bin_wall_ny", (bx, by - half + w / 2, h), (half - w, w / 2, h), BIN_RGBA, static)


def _add_targets(spec: mujoco.MjSpec, cell: CellConfig) -> None:
    """Ten free target cylinders, parked upright on the floor out of the robot's reach."""
    t = cell.target
    for k in range(cell.n_targets):
        body = spec.worldbody.add_body(name=target_name(k), pos=list(cell.park_position(k)))
        body.sleep = mujoco.mjtSleepPolicy.mjSLEEP_INIT
        body.add_freejoint(name=f"{target_name(k)}_joint")
        body.add_geom(
            name=target_name(k),
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[t.radius, t.length / 2.0, 0],
            mass=t.mass,
            rgba=list(TARGET_RGBA),
            condim=4,
            friction=[t.friction, 0.01, 0.0001],
            priority=1,
            solref=list(GRASP_SOLREF),
            solimp=list(GRASP_SOLIMP),
        )


def _dress(
    spec: mujoco.MjSpec, cell: CellConfig, visual: mujoco.MjsDefault, mesh_dir: Path | str
) -> None:
    """The look of robot and cell (visual-only geoms, materials, lights): see
    :mod:`kr210_sim.dressing`."""
    s, b = cell.shelf, cell.bin
    dressing.add_materials(spec)
    dressing.dress_robot(spec, visual, mesh_dir)
    dressing.dress_floor(
        spec,
        visual,
        robot_xy=(0.0, 0.0),
        plate_half=0.6,
        marked=(-1.3, -1.6, s.x_front + s.depth + 0.25, b.center_xy[1] + b.outer_size / 2 + 0.4),
        hall=(-6.0, -6.0, 6.5, 6.0),
    )
    shelf = spec.body("shelf")
    dressing.hide(shelf)
    dressing.dress_shelf(
        spec,
        shelf,
        visual,
        x_front=s.x_front,
        depth=s.depth,
        half_width=s.half_width,
        height=s.height,
        board_tops=s.board_tops,
        board_thickness=s.board_thickness,
        upright_y=[
            sign * (inner + outer) / 2.0
            for sign, (inner, outer) in (
                (-1, s.post_y),
                (-1, s.divider_y),
                (1, s.divider_y),
                (1, s.post_y),
            )
        ],
    )
    bin_body = spec.body("bin")
    dressing.hide(bin_body)
    dressing.dress_bin(spec, bin_body, visual, b.center_xy, b.outer_size, b.height, b.floor_top)
    dressing.add_lights(spec, center=(1.0, 1.0, 1.0))


def build_spec(
    cell: CellConfig | None = None,
    urdf_path: Path | str = URDF_PATH,
    mesh_dir: Path | str = MESH_DIR,
) -> mujoco.MjSpec:
    """Build the whole cell as an :class:`mujoco.MjSpec`.

    Args:
        cell: Cell layout (defaults to the published cell).
        urdf_path: The KR210 URDF.
        mesh_dir: Folder of the URDF's visual meshes.

    Returns:
        The spec, ready to compile or save.

    Raises:
        SceneError: When the URDF cannot be read or compiled.
    """
    cell = cell or CellConfig()
    urdf_path = Path(urdf_path)
    if not urdf_path.is_file():
        raise SceneError(f"URDF not found: {urdf_path}")
    try:
        spec = mujoco.MjSpec.from_file(str(urdf_path))
    except Exception as exc:
        raise SceneError(f"MuJoCo cannot read URDF {urdf_path}: {exc}") from exc
    spec.modelname = "kr210_cell"
    spec.meshdir = str(Path(mesh_dir).resolve())
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
    # Sleeping: resting bodies (parked spares, cylinders in the bin) leave the solver, which
    # keeps the step rate of a full bin close to that of an empty cell (~4x faster).
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    spec.visual.global_.offwidth, spec.visual.global_.offheight = OFFSCREEN_SIZE
    spec.visual.quality.shadowsize = 4096
    spec.stat.center = [1.0, 0.6, 1.2]
    spec.stat.extent = 4.0

    visual = spec.add_default("visual", spec.default)
    visual.geom.contype, visual.geom.conaffinity, visual.geom.group = 0, 0, 2
    visual.geom.density = 0
    collision = spec.add_default("collision", spec.default)
    collision.geom.group = 3
    static = spec.add_default("static", spec.default)
    static.geom.group = 0

    _configure_robot(spec, visual, collision)
    _add_world(spec, cell, static)
    _add_shelf(spec, cell, static)
    _add_bin(spec, cell, static)
    _add_targets(spec, cell)
    _dress(spec, cell, visual, mesh_dir)
    # Contact sensors: how many contacts the moving robot (link_1's subtree) has with the shelf
    # and with the bin, read by the control loop every tick.
    for env in ("shelf", "bin"):
        spec.add_sensor(
            name=f"robot_{env}_contacts",
            type=mujoco.mjtSensor.mjSENS_CONTACT,
            objtype=mujoco.mjtObj.mjOBJ_XBODY,
            objname="link_1",
            reftype=mujoco.mjtObj.mjOBJ_BODY,
            refname=env,
            intprm=[1, 0, 1],  # data = "found" (count), no reduction
        )

    try:
        model = spec.compile()
    except Exception as exc:
        raise SceneError(f"the cell does not compile: {exc}") from exc
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    dof = [model.jnt_dofadr[model.joint(n).id] for n in ARM_JOINTS]
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    _add_actuators(spec, np.array([full[i, i] for i in dof]))
    try:
        model = spec.compile()
    except Exception as exc:
        raise SceneError(f"the cell does not compile with actuators: {exc}") from exc
    ctrl = np.zeros(model.nu)
    spec.add_key(name="home", qpos=model.qpos0.tolist(), ctrl=ctrl.tolist())
    return spec


def build_scene(out_dir: Path | str = SCENES_DIR, cell: CellConfig | None = None) -> list[Path]:
    """Write the cell MJCF to ``out_dir`` (mesh paths relative to it).

    Args:
        out_dir: Destination folder (``scenes/`` by default).
        cell: Cell layout (defaults to the published cell).

    Returns:
        The files written.

    Raises:
        ConfigError: When ``out_dir`` cannot be created or written (checked before building).
        SceneError: When the cell cannot be built.
    """
    out = check_folder(out_dir)
    path = out / SCENE_PATH.name
    if path.is_dir():
        raise ConfigError(f"cannot write {path}: it is a folder")
    spec = build_spec(cell)
    abs_dir = spec.meshdir
    xml = spec.to_xml()
    rel_dir = Path(_relpath(MESH_DIR, out)).as_posix()
    xml = xml.replace(f'meshdir="{abs_dir}"', f'meshdir="{rel_dir}"', 1)
    if rel_dir not in xml:
        raise SceneError("could not make the mesh folder relative in the generated MJCF")
    header = (
        "<!-- Generated by `python -m kr210_sim build-scene` from assets/kr210/kr210.urdf and "
        "kr210_sim/config.py. Do not edit by hand. -->\n"
    )
    return [write_bytes_atomic(path, (header + xml).encode())]


def _relpath(target: Path, start: Path) -> str:
    import os

    return os.path.relpath(target.resolve(), start.resolve())


def load_model(path: Path | str | None = None) -> mujoco.MjModel:
    """Load a cell model: the MJCF at ``path``, or the committed scene when None.

    Raises:
        SceneError: When the file is missing or MuJoCo rejects it.
    """
    path = Path(path) if path is not None else SCENE_PATH
    if path.is_dir():
        raise SceneError(f"scene {path} is a folder: give the MJCF file (e.g. {SCENE_PATH.name})")
    if not path.is_file():
        raise SceneError(f"scene not found: {path} (run `python -m kr210_sim build-scene`)")
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except Exception as exc:
        reason = " ".join(str(exc).split())  # MuJoCo's messages span several lines
        raise SceneError(f"MuJoCo cannot load scene {path}: {reason}") from exc


@dataclass(frozen=True, slots=True)
class CellHandles:
    """Indices into a compiled cell model, looked up once by name.

    Attributes:
        arm_qpos: qpos addresses of joint_1..joint_6.
        arm_dof: dof addresses of joint_1..joint_6.
        arm_act: Actuator ids of joint_1..joint_6.
        finger_qpos: qpos addresses of the right and left finger joints.
        grip_act: Actuator id of the gripper.
        gripper_body: Body id of gripper_link.
        grip_site: Site id of the grasp centre between the fingers.
        finger_geoms: Geom ids of the right and left finger pads.
        lip_geoms: Geom ids of the right and left fingertip lips.
        robot_geoms: Collision geom ids of the robot.
        shelf_geoms: Geom ids of the shelf.
        bin_geoms: Geom ids of the bin.
        target_bodies: Body ids of the targets.
        target_geoms: Geom ids of the targets.
        target_qpos: qpos address of each target's free joint.
        target_dof: dof address of each target's free joint.
        env_contact_sensors: sensordata addresses of the robot-shelf and robot-bin counts.
    """

    arm_qpos: npt.NDArray[np.int_]
    arm_dof: npt.NDArray[np.int_]
    arm_act: npt.NDArray[np.int_]
    finger_qpos: npt.NDArray[np.int_]
    grip_act: int
    gripper_body: int
    grip_site: int
    finger_geoms: tuple[int, int]
    lip_geoms: tuple[int, int]
    robot_geoms: frozenset[int]
    shelf_geoms: frozenset[int]
    bin_geoms: frozenset[int]
    target_bodies: npt.NDArray[np.int_]
    target_geoms: npt.NDArray[np.int_]
    target_qpos: npt.NDArray[np.int_]
    target_dof: npt.NDArray[np.int_]
    env_contact_sensors: tuple[int, int]

    @classmethod
    def from_model(cls, model: mujoco.MjModel) -> CellHandles:
        """Look up every handle by name.

        Raises:
            SceneError: When a named element is missing (lists what exists).
        """

        def jid(name: str) -> int:
            i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            if i < 0:
                names = [model.joint(k).name for k in range(model.njnt)]
                raise SceneError(
                    f"scene is not a kr210_sim cell: it has no joint {name!r} (joints: {names})"
                )
            return int(i)

        def oid(kind: mujoco.mjtObj, name: str) -> int:
            i = mujoco.mj_name2id(model, kind, name)
            if i < 0:
                raise SceneError(
                    f"scene is not a kr210_sim cell: it has no {kind.name[6:].lower()} {name!r}"
                )
            return int(i)

        arm = [jid(n) for n in ARM_JOINTS]
        fingers = [jid(n) for n in FINGER_JOINTS]
        robot_bodies = {oid(mujoco.mjtObj.mjOBJ_BODY, n) for n in ARM_LINKS} | {
            oid(mujoco.mjtObj.mjOBJ_BODY, n)
            for n in ("right_gripper_finger_link", "left_gripper_finger_link")
        }
        shelf = oid(mujoco.mjtObj.mjOBJ_BODY, "shelf")
        bin_ = oid(mujoco.mjtObj.mjOBJ_BODY, "bin")
        targets = []
        k = 0
        while mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, target_name(k)) >= 0:
            targets.append(oid(mujoco.mjtObj.mjOBJ_BODY, target_name(k)))
            k += 1
        if not targets:
            raise SceneError("scene has no target cylinders (target_0 ...)")
        target_joints = [jid(f"{target_name(i)}_joint") for i in range(len(targets))]
        gb = model.geom_bodyid
        return cls(
            arm_qpos=np.array([model.jnt_qposadr[j] for j in arm]),
            arm_dof=np.array([model.jnt_dofadr[j] for j in arm]),
            arm_act=np.array([oid(mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in ARM_JOINTS]),
            finger_qpos=np.array([model.jnt_qposadr[j] for j in fingers]),
            grip_act=oid(mujoco.mjtObj.mjOBJ_ACTUATOR, "gripper"),
            gripper_body=oid(mujoco.mjtObj.mjOBJ_BODY, "gripper_link"),
            grip_site=oid(mujoco.mjtObj.mjOBJ_SITE, "gripper"),
            finger_geoms=(
                oid(mujoco.mjtObj.mjOBJ_GEOM, "right_finger_pad"),
                oid(mujoco.mjtObj.mjOBJ_GEOM, "left_finger_pad"),
            ),
            lip_geoms=(
                oid(mujoco.mjtObj.mjOBJ_GEOM, "right_finger_lip"),
                oid(mujoco.mjtObj.mjOBJ_GEOM, "left_finger_lip"),
            ),
            robot_geoms=frozenset(
                g
                for g in range(model.ngeom)
                if gb[g] in robot_bodies and model.geom_contype[g] != 0
            ),
            shelf_geoms=frozenset(g for g in range(model.ngeom) if gb[g] == shelf),
            bin_geoms=frozenset(g for g in range(model.ngeom) if gb[g] == bin_),
            target_bodies=np.array(targets),
            target_geoms=np.array(
                [oid(mujoco.mjtObj.mjOBJ_GEOM, target_name(i)) for i in range(len(targets))]
            ),
            target_qpos=np.array([model.jnt_qposadr[j] for j in target_joints]),
            target_dof=np.array([model.jnt_dofadr[j] for j in target_joints]),
            env_contact_sensors=tuple(  # type: ignore[arg-type]
                int(model.sensor_adr[oid(mujoco.mjtObj.mjOBJ_SENSOR, f"robot_{env}_contacts")])
                for env in ("shelf", "bin")
            ),
        )
