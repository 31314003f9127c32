"""The one thing pyproject.toml does not declare: the optional C extension.

The single-pose IK compiled (``kr210_sim/robot/_ik_native.c``): optional, so that an install
without a compiler still works on the pure-Python path (``ik_scalar.NATIVE`` says which is in
use). No -ffast-math, and no fused multiply-add, so it gives the pure-Python path's floats.
Everything else (metadata, packages, data) is in ``pyproject.toml``.
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "kr210_sim.robot._ik_native",
            sources=["kr210_sim/robot/_ik_native.c"],
            extra_compile_args=["-O2", "-ffp-contract=off", "-fno-fast-math"],
            optional=True,
        )
    ]
)
