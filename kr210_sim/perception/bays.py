"""The numbers the pipeline takes from a cell file: a slot's bay as a box.

The pipeline itself knows nothing of cell files (it takes a :class:`BayBox`); :func:`bay_box`
reads it off a cell's shelf, as the MJCF builds the shelf (:mod:`kr210_sim.cell.mjcf`). (A
compiled cell's kinds: :func:`kr210_sim.sensors.recognisers.cell_kinds`.)
"""

from __future__ import annotations

from kr210_sim.cell.spec import (
    SHELF_BOARD_THICKNESS,
    SHELF_POST_WIDTH,
    ShelfSpec,
)
from kr210_sim.perception.cloud import BayBox

#: Thickness of the shelf's back panel [m] (the MJCF's ``shelf_back``).
SHELF_BACK_THICKNESS = 0.02


def bay_box(shelf: ShelfSpec, slot: int) -> BayBox:
    """The inside of slot ``slot``'s bay: from its board's top to the underside of the board
    (or top panel) above, between its posts, from the open front to the back panel.

    Args:
        shelf: The cell's shelf.
        slot: The slot's number (1 = bottom row, left as the robot sees it).

    Raises:
        ValueError: When the shelf has no such slot.
    """
    n = shelf.rows * shelf.columns
    if not 1 <= slot <= n:
        raise ValueError(f"slot {slot} is not on the shelf (slots 1-{n})")
    row = (slot - 1) // shelf.columns
    tops = shelf.board_tops
    ceiling = tops[row + 1] if row + 1 < len(tops) else shelf.height
    ceiling -= SHELF_BOARD_THICKNESS
    _, y, floor = shelf.slot_local(slot)
    front = -shelf.depth / 2.0
    back = shelf.depth / 2.0 - SHELF_BACK_THICKNESS
    centre = shelf.to_world(((front + back) / 2.0, y, (floor + ceiling) / 2.0))
    half = (
        (back - front) / 2.0,
        (shelf.column_pitch - SHELF_POST_WIDTH) / 2.0,
        (ceiling - floor) / 2.0,
    )
    return BayBox((float(centre[0]), float(centre[1]), float(centre[2])), shelf.yaw, half)
