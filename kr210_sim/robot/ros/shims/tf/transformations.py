"""tf.transformations: :mod:`kr210_sim.robot.ros.tf_transformations` itself (every name, the
private ones too)."""

import sys

from kr210_sim.robot.ros import tf_transformations

sys.modules[__name__] = tf_transformations
