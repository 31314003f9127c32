"""What perception saw, drawn on the video (``run --perceive --video``).

The runner's status says, from a cycle's look on, what was recognised (``seen``: the label, its
confidence, whether it was the target) and where (``seen_at``: the estimated centre [m], base
frame = world). The text goes into the overlay's lines
(:func:`kr210_sim.media.video.overlay_lines`); :class:`SeenMarker` draws a ring and the label at
the estimate's pixel in every view of the frame, projected through the view's camera at that
frame's state (a camera on the arm moves with it), so the picture shows where the arm is about
to reach.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from kr210_sim.media.recording import FrameStatus
from kr210_sim.media.render import check_camera
from kr210_sim.media.video import VideoSettings
from kr210_sim.perception.camera import Intrinsics, optical_from_mujoco, project

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]

#: The marker's colour (RGB).
COLOUR = (255, 220, 0)


class SeenMarker:
    """Projects a perceived position into a frame's views and marks it.

    Args:
        model: The cell model the frames show.
        settings: The video's cameras and size.
    """

    def __init__(self, model: mujoco.MjModel, settings: VideoSettings) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.cameras = [check_camera(model, c) for c in settings.cameras]
        self.width, self.height = settings.width, settings.height
        self.radius = max(6, settings.height // 40)
        self._font: object | None = None

    def pixels(self, qpos: FloatArray, point: npt.ArrayLike) -> list[tuple[float, float] | None]:
        """Where ``point`` [m] (world) lies in each view at the state ``qpos``: (u, v) [px]
        within that view, or None when it is behind the camera or outside the view."""
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        out: list[tuple[float, float] | None] = []
        for cam in self.cameras:
            T = optical_from_mujoco(self.data.cam_xpos[cam], self.data.cam_xmat[cam])
            K = Intrinsics.from_fovy(self.width, self.height, float(self.model.cam_fovy[cam]))
            p = (np.asarray(point, dtype=np.float64) - T[:3, 3]) @ T[:3, :3]
            (u, v) = project(p, K)[0]
            inside = np.isfinite(u) and 0 <= u < self.width and 0 <= v < self.height
            out.append((float(u), float(v)) if inside else None)
        return out

    def draw(
        self, frame: npt.NDArray[np.uint8], qpos: FloatArray, status: FrameStatus
    ) -> npt.NDArray[np.uint8]:
        """Mark ``status.seen_at`` in every view of ``frame`` (in place): a ring and the label."""
        if status.seen_at is None:
            return frame
        from PIL import Image, ImageDraw, ImageFont

        if self._font is None:
            self._font = ImageFont.load_default(size=max(12, self.height // 36))
        img = Image.fromarray(frame)
        pen = ImageDraw.Draw(img)
        r = self.radius
        text = status.seen.split(" (")[0]
        for view, uv in enumerate(self.pixels(qpos, status.seen_at)):
            if uv is None:
                continue
            u, v = uv[0] + view * self.width, uv[1]
            pen.ellipse((u - r, v - r, u + r, v + r), outline=COLOUR, width=3)
            pen.line((u - r / 2, v, u + r / 2, v), fill=COLOUR, width=1)
            pen.line((u, v - r / 2, u, v + r / 2), fill=COLOUR, width=1)
            right = (view + 1) * self.width
            width = pen.textlength(text, font=self._font)  # type: ignore[arg-type]
            x = u + r + 4 if u + r + 4 + width <= right else u - r - 4 - width  # inside the view
            pen.text((x, v - r), text, fill=COLOUR, font=self._font)  # type: ignore[arg-type]
        frame[:] = np.asarray(img)
        return frame
