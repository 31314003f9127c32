"""std_msgs.msg: its messages (:mod:`kr210_sim.exercise.messages`)."""

from kr210_sim.exercise.messages import (
    Bool,
    ColorRGBA,
    Empty,
    Float32,
    Float64,
    Float64MultiArray,
    Header,
    Int32,
    Int64,
    String,
)

__all__ = [
    "Bool",
    "ColorRGBA",
    "Empty",
    "Float32",
    "Float64",
    "Float64MultiArray",
    "Header",
    "Int32",
    "Int64",
    "String",
]
