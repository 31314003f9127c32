"""The simulated sensors: RGB-D looks of the cell's cameras with a real sensor's noise, the truth
about the shelf for scoring, and rendered samples for training (the MuJoCo side of perception:
it imports :mod:`kr210_sim.perception.camera`, never the reverse)."""

from __future__ import annotations

from kr210_sim.sensors.noise import MODELS, DepthNoise, apply_noise
from kr210_sim.sensors.render import SensorRig
from kr210_sim.sensors.samples import Sample, render_samples
from kr210_sim.sensors.truth import TruthObject, shelf_truth

__all__ = [
    "MODELS",
    "DepthNoise",
    "Sample",
    "SensorRig",
    "TruthObject",
    "apply_noise",
    "render_samples",
    "shelf_truth",
]
