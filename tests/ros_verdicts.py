"""Original-form servers written for the tests of the verdicts (issue 40 item 3): each is the
NumPy server of :mod:`ros_class` (written for these tests, none copied from a public
repository) with one change that real submissions showed:

* ``straight``: no special case at the singular wrist, so the pose at q5 = 0 exactly gets
  theta4 and theta6 from rounding noise; every other pose is exact;
* ``early``: the wrist taken as straight below sin(theta5) = 0.002, so the poses at
  q5 = +-0.001 miss their orientation by up to 2 mrad (a near miss);
* ``shifted``: the wrist centre moved 281 mm down, the same vector on every pose;
* ``ragged``: keeps each pose's index beside its angles in one NumPy array, a ragged one, which
  NumPy 1.11-1.13 made an object array of and NumPy 1.24 and later refuse.
"""

from __future__ import annotations

from pathlib import Path

import ros_class

SINGULAR_BRANCH = "        if s5 < 1e-9:\n"
SOLVED = "            q = solve_pose(np.array([px, py, pz]), R_ee)\n"
WRIST_CENTRE = "    wc = p - DG * R[:, 2]\n"


def _changed(old: str, new: str) -> str:
    source = ros_class.numpy_server()
    assert old in source
    return source.replace(old, new)


def servers() -> dict[str, str]:
    """Each server's source, by student name."""
    return {
        "straight": _changed(SINGULAR_BRANCH, "        if False:\n"),
        "early": _changed(SINGULAR_BRANCH, "        if s5 < 0.002:\n"),
        "shifted": _changed(
            WRIST_CENTRE, "    wc = p - DG * R[:, 2] + np.array([0.0, 0.0, -0.281])\n"
        ),
        "ragged": _changed(
            SOLVED,
            SOLVED
            + "            log = np.array([x, q])  # the pose's index beside its angles\n"
            + "            q = log[1]\n",
        ),
    }


def straight_in_our_form() -> str:
    """``straight``'s IK in our contract, ``solve(T, q_ref)`` (Python 3)."""
    ik = ros_class.NUMPY_IK.substitute(a3="-0.054", dg="0.303").replace(
        SINGULAR_BRANCH, "        if False:\n"
    )
    return ik.replace("xrange", "range").replace("\t", " " * 8) + (
        "\n\ndef solve(T, q_ref):\n    return solve_pose(T[:3, 3], T[:3, :3])\n"
    )


def write(folder: Path, names: tuple[str, ...] | None = None) -> Path:
    """Write the servers (or those ``names``) into ``folder``, one repository each."""
    for name, source in servers().items():
        if names is None or name in names:
            path = folder / name / "kuka_arm" / "scripts" / "IK_server.py"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(source)
    return folder
