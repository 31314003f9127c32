"""How far the robot's visual meshes stick out of its collision geometry, per link.

Prints, for every link with a visual mesh, the largest distance [mm] of a visual vertex outside
the link's colliders: the URDF's primitives alone (what the contact monitor had before the hull
colliders), and primitives plus the hull colliders (now).
Run: python benchmarks/collision_geometry.py
"""

from __future__ import annotations

import sys
from pathlib import Path

# The test helpers (tests/) are not part of the package.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from colliders import stick_out

from kr210_sim.cell.load import load_model


def main() -> None:
    model = load_model()
    before, after = stick_out(model, with_hulls=False), stick_out(model)
    print(f"{'link':<28} {'primitives only [mm]':>21} {'with hulls [mm]':>16}")
    for name in after:
        print(
            f"{name:<28} {1000 * before.get(name, float('nan')):>21.1f} {1000 * after[name]:>16.2f}"
        )


if __name__ == "__main__":
    main()
