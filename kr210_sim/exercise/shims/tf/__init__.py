"""tf, as an IK server uses it: ``tf.transformations`` (:mod:`kr210_sim.exercise.
tf_transformations`) and tf's frame classes (:mod:`kr210_sim.exercise.frames`)."""

from kr210_sim.exercise.frames import (
    ConnectivityException,
    ExtrapolationException,
    LookupException,
    TransformBroadcaster,
    Transformer,
    TransformListener,
)
from kr210_sim.exercise.frames import TransformException as Exception

from . import transformations

__all__ = [
    "ConnectivityException",
    "Exception",
    "ExtrapolationException",
    "LookupException",
    "TransformBroadcaster",
    "TransformListener",
    "Transformer",
    "transformations",
]
