"""From looks at a bay to the target's pose: crop, thin, take out the shelf, cluster, recognise,
fit, grasp (:func:`perceive`).

Every way a look can fail says why: a sensor that sees nothing of the bay, a board that is not
where the layout puts it (a wrong extrinsic), a target not among the clusters. A target
recognised with a confidence under :data:`CONFIDENT` is returned flagged, so that the caller can
take a second look from the wrist camera; it is never returned as a confident pose. So is a
cylinder whose radius no look measured (:attr:`Percept.precise`): its centre is then only as good
as the kind's nominal radius is for this one.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from threadpoolctl import ThreadpoolController

from kr210_sim.perception.camera import Observation
from kr210_sim.perception.cloud import BayBox, bay_cloud, voxel_downsample
from kr210_sim.perception.clusters import cluster
from kr210_sim.perception.features import features, normals
from kr210_sim.perception.fits import Fit, fit_box, fit_cylinder, fit_sphere
from kr210_sim.perception.grasp import Grasp, GripperEnvelope, choose_grasp
from kr210_sim.perception.kinds import Detection, Pose
from kr210_sim.perception.model import RecognitionModel
from kr210_sim.perception.planes import REQUIRED, remove_shelf

FloatArray = npt.NDArray[np.float64]

#: A target recognised with less confidence than this asks for a second look (the SVM's
#: Platt-calibrated probability: about 0.75 for the right kind on the cluttered cell's looks).
CONFIDENT = 0.6
#: Margin around the bay's box kept for the plane fits [m].
CROP_MARGIN = 0.03
#: More margin below the bay's floor [m]: what lies under a fitted board shows a wrong one.
CROP_BELOW = 0.1
#: How far inside the posts and the back panel an object's point must lie [m]: a rendered
#: rack's uprights and bracing stand there, in the far look's noise.
INSET = 0.01
#: How far above the board's top (as the layout puts it) an object's point must lie [m]: the
#: objects stand on it, and a rack's beam rises to 5 mm under it.
ABOVE_BOARD = 0.008
#: How far above the board a cluster's lowest points may lie and it still stand on it [m].
STANDING = 0.03
#: Fewest valid points of the bay a look needs.
MIN_BAY_POINTS = 200
#: The voxel, in pixels at the bay's range.
VOXEL_PX = 1.5

#: The native thread pools (BLAS, OpenMP) the pipeline holds to one thread while it runs: its
#: arrays are small (a few thousand points a cluster), so a second BLAS thread only spins, and
#: a look cost about 1.4 times the CPU time with two (measured on a 2-core machine).
_POOLS: ThreadpoolController | None = None


def _pools() -> ThreadpoolController:
    global _POOLS
    if _POOLS is None:
        _POOLS = ThreadpoolController()
    return _POOLS


@dataclass(frozen=True)
class Look:
    """What one observation gave.

    Attributes:
        sensor: The sensor's name.
        detections: Every cluster recognised and fitted, largest first.
        problems: Why the look cannot be trusted (empty when it can).
        timing: CPU time of each step [s].
        obstacle_points: (M, 3) points of the clusters and the posts [m] (base frame).
        obstacle_owner: (M,) index of each point's detection (len(detections): the posts).
    """

    sensor: str
    detections: tuple[Detection, ...]
    problems: tuple[str, ...]
    timing: dict[str, float]
    obstacle_points: FloatArray = field(repr=False)
    obstacle_owner: npt.NDArray[np.intp] = field(repr=False)


@dataclass(frozen=True)
class Percept:
    """What :func:`perceive` found.

    Attributes:
        pick_label: The kind looked for.
        target: The target's detection (None: not seen).
        grasp: A grasp that clears its neighbours (None: see ``reason``).
        confident: Whether the target was recognised with confidence at least
            :data:`CONFIDENT` and a good fit; when False a second look is wanted.
        precise: Whether the target's pose was fitted from its measured size. A cylinder's
            centre is fitted at its radius behind the side seen, so with the kind's nominal
            radius (taken when the arc's noise is over 4 % of it: a far look's) it is off by
            about the object's own radius' difference from the nominal one (up to 10 mm for
            radii of 40-60 mm against a nominal 50): when False a closer look is wanted too.
        reason: Why the target was not seen, is not trusted or cannot be grasped ("" if all is
            well).
        looks: Each observation's result, in order.
        cpu_time: CPU time of the whole perception [s].
    """

    pick_label: str
    target: Detection | None
    grasp: Grasp | None
    confident: bool
    reason: str
    looks: tuple[Look, ...]
    cpu_time: float
    precise: bool = True

    @property
    def seen(self) -> bool:
        """Whether the target was found at all."""
        return self.target is not None


def _fit(
    shape: str,
    nominal: tuple[float, ...],
    pts: FloatArray,
    nrm: FloatArray,
    floor_z: float,
    toward_camera: FloatArray,
) -> Fit:
    if shape == "cylinder":
        return fit_cylinder(pts, nrm, floor_z, nominal[0], toward_camera)
    if shape == "box":
        return fit_box(pts, nrm, floor_z, toward_camera, (nominal[0], nominal[1], nominal[2]))
    return fit_sphere(pts, nominal[0])


def _posts(box: BayBox, step: float = 0.02) -> FloatArray:
    """Points on the inner faces of the bay's posts, in the base frame [m]."""
    hx, hy, hz = box.half
    xs = np.arange(-hx, hx + 1e-9, step)
    zs = np.arange(-hz, hz + 1e-9, step)
    X, Z = np.meshgrid(xs, zs)
    faces = [np.column_stack((X.ravel(), np.full(X.size, s * hy), Z.ravel())) for s in (-1, 1)]
    return box.to_base(np.vstack(faces))


@dataclass(frozen=True)
class Segments:
    """A look's cloud without the shelf, in clusters (in the bay's box frame).

    Attributes:
        points: (N, 3) points [m] of the objects.
        colours: (N, 3) their colours.
        groups: Each cluster's indices into ``points``, largest first.
        floor: (a, b, c) of the board's plane z = a x + b y + c [m].
        sigma: The depth noise at the bay, from the board's plane [m].
        voxel: The voxel the cloud was thinned to [m].
        problems: Why the look cannot be trusted (then there are no groups).
        timing: CPU time of each step [s].
    """

    points: FloatArray
    colours: npt.NDArray[np.uint8]
    groups: list[npt.NDArray[np.intp]]
    floor: tuple[float, float, float]
    sigma: float
    voxel: float
    problems: tuple[str, ...]
    timing: dict[str, float]


def segment(obs: Observation, box: BayBox, rng: np.random.Generator) -> Segments:
    """Crop, thin, take out the shelf and cluster one look.

    Args:
        obs: The observation.
        box: The bay's inside.
        rng: Seeds RANSAC.
    """
    timing: dict[str, float] = {}
    t0 = time.process_time()
    T = np.asarray(obs.T_base_camera, dtype=np.float64)
    rng_m = float(np.linalg.norm(box.to_local(T[:3, 3])))
    voxel = float(np.clip(VOXEL_PX * rng_m / obs.intrinsics.fx, 0.004, 0.01))
    local, colours = bay_cloud(obs, box, CROP_MARGIN, voxel, CROP_BELOW)
    nothing: tuple[FloatArray, npt.NDArray[np.uint8], list[npt.NDArray[np.intp]]] = (
        np.zeros((0, 3)),
        np.zeros((0, 3), dtype=np.uint8),
        [],
    )
    if len(local) < MIN_BAY_POINTS:
        timing["cloud"] = time.process_time() - t0
        why = (
            f"sensor {obs.sensor} sees nothing of the bay ({len(local)} valid points in it): "
            "is it pointed at the bay, and is its depth valid?"
        )
        return Segments(*nothing, (0.0, 0.0, 0.0), 0.0, voxel, (why,), timing)
    local, colours = voxel_downsample(local, colours, voxel)
    t1 = time.process_time()
    timing["cloud"] = t1 - t0
    cam_z = float(box.to_local(T[:3, 3])[2])
    required = (
        REQUIRED if cam_z > -box.half[2] + 0.05 else tuple(f for f in REQUIRED if f != "board")
    )
    removal = remove_shelf(local, box.half, rng, required=required)
    t2 = time.process_time()
    timing["planes"] = t2 - t1
    if removal.problems:
        return Segments(*nothing, (0.0, 0.0, 0.0), 0.0, voxel, removal.problems, timing)
    board = removal.planes[0]
    sigma = max(board.band / 3.0, 0.0005)
    inner = np.asarray(box.half) - (0.0, INSET, 0.0)
    inside = removal.keep & np.all(np.abs(local) <= inner, axis=1)
    inside &= (local[:, 0] <= inner[0] - INSET) & (local[:, 2] >= -inner[2] + ABOVE_BOARD)
    pts, cols = local[inside], colours[inside]
    groups = cluster(pts, cols, eps=max(2.5 * voxel, 1.5 * sigma))
    # what does not stand on the board is not an object (a rack's beam under the board above)
    floor = -box.half[2] + ABOVE_BOARD
    groups = [g for g in groups if np.percentile(pts[g, 2], 2.0) < floor + STANDING]
    timing["cluster"] = time.process_time() - t2
    return Segments(pts, cols, groups, board.coef, sigma, voxel, (), timing)


def analyse(
    obs: Observation, box: BayBox, model: RecognitionModel, rng: np.random.Generator
) -> Look:
    """One look at one bay: every cluster in it recognised and fitted.

    Args:
        obs: The observation.
        box: The bay's inside.
        model: The recogniser.
        rng: Seeds RANSAC.
    """
    seg = segment(obs, box, rng)
    timing = dict(seg.timing)
    empty = np.zeros((0, 3)), np.zeros(0, dtype=np.intp)
    if seg.problems:
        return Look(obs.sensor, (), seg.problems, timing, *empty)
    t3 = time.process_time()
    T = np.asarray(obs.T_base_camera, dtype=np.float64)
    cam_local = box.to_local(T[:3, 3])
    pts, cols, groups, sigma = seg.points, seg.colours, seg.groups, seg.sigma
    feats, nrms = [], []
    for idx in groups:
        nv = normals(pts[idx])
        feats.append(features(pts[idx], cols[idx], nv))
        nrms.append(nv[0])
    probs = model.probabilities(np.array(feats)) if feats else np.zeros((0, 0))
    t4 = time.process_time()
    timing["recognise"] = t4 - t3
    detections = []
    labels = model.labels
    for k, idx in enumerate(groups):
        best = int(np.argmax(probs[k]))
        kind = model.kind(labels[best])
        centroid = pts[idx].mean(axis=0)
        toward = cam_local - centroid
        floor_z = -box.half[2]  # objects stand on the board's top, where the layout puts it
        fit = _fit(kind.shape, kind.size, pts[idx], nrms[k], floor_z, toward)
        conf = float(probs[k, best])
        notes = []
        height = 2.0 * fit.size[0] if kind.shape == "sphere" else fit.size[-1]
        if abs(height - kind.height) > max(0.2 * kind.height, 3 * sigma):
            conf *= 0.5
            notes.append(f"height {height * 1000:.0f} mm, the kind's {kind.height * 1000:.0f}")
        if not fit.measured_size:
            notes.append("size not measured (too little of it seen): the kind's used")
        R = box.rotation
        pose = Pose(
            position=box.to_base(fit.position),
            axis=R @ fit.axis,
            frame=R @ fit.frame,
            size=fit.size,
            residual=fit.residual,
        )
        detections.append(
            Detection(
                kind.name,
                conf,
                kind.shape,
                pose,
                len(idx),
                box.to_base(pts[idx].mean(axis=0)),
                tuple(notes),
                fit.measured_size,
            )
        )
    timing["fit"] = time.process_time() - t4
    owner = [np.full(len(g), k, dtype=np.intp) for k, g in enumerate(groups)]
    members = [box.to_base(pts[g]) for g in groups]
    posts = _posts(box)
    ob_pts = np.vstack([*members, posts])
    ob_own = np.concatenate([*owner, np.full(len(posts), len(groups), dtype=np.intp)])
    return Look(obs.sensor, tuple(detections), (), timing, ob_pts, ob_own)


def perceive(
    observations: Sequence[Observation],
    pick_label: str,
    bay: BayBox,
    model: RecognitionModel,
    seed: int = 0,
    grasp_dz: float = 0.0,
    envelope: GripperEnvelope | None = None,
    done: Sequence[Look] = (),
) -> Percept:
    """The target's pose and a grasp, from one or more looks at its bay.

    Each look is analysed on its own (one thread of BLAS); the target is the detection labelled
    ``pick_label`` that is confident, then whose size was measured (a close look), then from the
    latest look, then with the highest confidence.

    Args:
        observations: The looks, the fixed sensor's first.
        pick_label: The kind to pick.
        bay: The bay's inside (from the cell's layout).
        model: The recogniser.
        seed: Seeds RANSAC.
        grasp_dz: Height of the fingers' centre above the target's centre [m].
        envelope: The gripper.
        done: The analyses of the first ``len(done)`` observations, from an earlier call (a
            second look adds to the first, which is not analysed again); ``cpu_time`` counts
            the looks analysed in this call only.

    Returns:
        The percept; ``reason`` says why when the target is not seen, not trusted or cannot be
        grasped.

    Raises:
        ValueError: When ``pick_label`` is not one of the model's kinds, or ``done`` holds
            more looks than there are observations or another sensor's.
    """
    t0 = time.process_time()
    try:
        model.kind(pick_label)
    except KeyError as exc:
        raise ValueError(str(exc.args[0])) from exc
    if len(done) > len(observations) or any(
        d.sensor != o.sensor for d, o in zip(done, observations, strict=False)
    ):
        raise ValueError("done must hold the analyses of the first observations, in order")
    rng = np.random.default_rng(seed)
    with _pools().limit(limits=1):
        new = tuple(analyse(o, bay, model, rng) for o in observations[len(done) :])
    looks = (*done, *new)
    best: tuple[tuple[bool, bool, int, float], int, Detection] | None = None
    for i, look in enumerate(looks):
        for d in look.detections:
            key = (d.confidence >= CONFIDENT, d.measured, i, d.confidence)
            if d.label == pick_label and (best is None or key > best[0]):
                best = (key, i, d)
    problems = [p for look in looks for p in look.problems]
    if best is None:
        seen = ", ".join(
            f"{look.sensor}: " + (", ".join(d.label for d in look.detections) or "nothing")
            for look in looks
        )
        why = "; ".join(problems) if problems else f"not seen (clusters: {seen})"
        return Percept(pick_label, None, None, False, why, looks, time.process_time() - t0)
    _, i, target = best
    conf = target.confidence
    rivals = [
        d
        for d in looks[i].detections
        if d is not target and d.label == pick_label and d.confidence >= 0.5
    ]
    reasons = []
    if conf < CONFIDENT:
        reasons.append(f"recognised with confidence {conf:.2f} only")
    if rivals:
        reasons.append(f"{len(rivals) + 1} clusters look like {pick_label}")
    reasons.extend(target.notes)
    look = looks[i]
    others = look.obstacle_owner != look.detections.index(target)
    owners = [d.label for d in look.detections] + ["shelf post"]
    assert target.pose is not None
    with _pools().limit(limits=1):
        grasp, why_not = choose_grasp(
            target.pose.position,
            look.obstacle_points[others],
            owners,
            look.obstacle_owner[others],
            grasp_dz,
            envelope,
        )
    if grasp is None:
        reasons.append(why_not)
    confident = conf >= CONFIDENT and not rivals
    precise = target.measured or target.shape != "cylinder"
    return Percept(
        pick_label,
        target,
        grasp,
        confident,
        "; ".join(reasons),
        looks,
        time.process_time() - t0,
        precise,
    )
