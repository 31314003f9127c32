"""tf.transformations: :mod:`kr210_sim.exercise.tf_transformations` itself (every name, the
private ones too)."""

import sys

from kr210_sim.exercise import tf_transformations

sys.modules[__name__] = tf_transformations
