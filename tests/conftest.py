"""Shared test setup: import kr210_sim first, so it picks the GL backend (EGL when there is no
display) before any test module imports mujoco."""

import kr210_sim  # noqa: F401
