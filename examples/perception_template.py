"""Template for bringing your own perception (``run --perceive --perception SPEC``).

Copy this file, fill in ``perceive`` and run::

    python -m kr210_sim run --cycles 3 --perceive --cell scenes/cells/cluttered.toml \\
        --perception my_perception.py:perceive

Your function is called once per look: the fixed shelf sensor's at each cycle's start, and the
wrist camera's when your best entry for the pick has a confidence under 0.6 (or there is none).
It runs in a process of its own, in the same jail as a student's IK: it can read the
interpreter's packages (NumPy, SciPy, scikit-learn, ...) and its own file, write only its
scratch folder (its working folder), has no network, and has ``--perception-timeout`` seconds
(default 10) per look. The arm is planned from what you return; the truth is used only to score
it (each cycle's ``perception`` block in the report).

The look (a dict; its arrays are fresh copies, yours to change):

===================  ======================================================================
key                  value
===================  ======================================================================
``rgb``              (H, W, 3) uint8 colour image, rows top to bottom, RGB order
``depth``            (H, W) float32 distance along the optical axis [m] (the z of the
                     camera frame, not along the ray); 0 where the sensor has no reading
``K``                (3, 3) float64 intrinsics [px]: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]];
                     pixel (u, v) = (column, row), (0, 0) the centre of the top-left pixel
``T_base_camera``    (4, 4) float64 pose of the camera's optical frame (x right, y down,
                     z forward) in the robot's base frame [m]: ``p_base = T @ p_camera``
``sensor``           the sensor's name (``shelf_rgbd``, ``gripper``, ...)
``time``             simulated time of the look [s]
``pick``             the label to pick this cycle
``pick_list``        the cell's pick list (labels picked in turn, cycle after cycle)
``kinds``            {label: {"shape": "cylinder" | "box" | "sphere", "size": [...] m,
                     "rgb": [r, g, b] in 0-1}}: cylinder size (radius, length), box full
                     extents (x, y, z), sphere (radius,)
``bay``              {"center": [x, y, z] m, "yaw": rad, "half": [hx, hy, hz] m}: the inside
                     of the bay the target stands in, a box in the base frame turned by yaw
                     about z (hx: depth into the shelf); its floor is the board's top
===================  ======================================================================

What you return: a list of dicts, one per object seen (at most 64):

==============  ========================================================================
key             value
==============  ========================================================================
``label``       a label (str), required; the pick is the entry labelled ``pick``
``position``    the object's centre in the base frame [m]: three finite numbers, required
``axis``        its axis (a cylinder's, a box's up) in the base frame: three finite
                numbers, not all zero; default [0, 0, 1]
``confidence``  a number in [0, 1]; default 1. Under 0.6 asks for a wrist look
==============  ========================================================================

An empty list means nothing was seen: the cycle is ``not_seen``. So is an exception, no answer in
time, ``None`` or a list not as above; the cycle's ``perception.reason`` then says what was wrong
in one line naming your function. NumPy arrays and NumPy numbers are fine anywhere a number is.
"""

from __future__ import annotations

from typing import Any


def perceive(look: dict[str, Any]) -> list[dict[str, Any]]:
    """The objects seen in ``look`` (see the module doc for both sides of the contract)."""
    # TODO: find look["pick"] in look["rgb"] and look["depth"], and say where it is.
    return []
