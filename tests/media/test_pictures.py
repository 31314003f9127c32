"""The README's pictures film the grasp: the states run from open fingers to a closed grip."""

from __future__ import annotations

import numpy as np

from kr210_sim.cell.handles import CellHandles
from kr210_sim.media.pictures import grasp_states


def test_grasp_states_cover_the_fingers_closing_on_the_cylinder() -> None:
    model, states, start = grasp_states(fps=10.0, before=1.0, after=1.6)
    h = CellHandles.from_model(model)
    times = np.array([d.time for d in states])
    assert np.all(np.diff(times) > 0) and np.allclose(np.diff(times), 0.1, atol=0.01)
    assert start == 10 and len(states) == 26
    q = np.array([d.qpos[h.finger_qpos] for d in states])  # right, left finger [m]
    assert np.allclose(q[:start], -0.03, atol=1e-3)  # wide open on the approach
    # closed on the 0.10 m cylinder: joint origin 0.0725 - pad half 0.013 - radius 0.05
    assert np.allclose(q[start + 2 :], 0.0095, atol=1.5e-3)
