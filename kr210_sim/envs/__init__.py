"""Gymnasium environments of the cell; importing this module registers them.

``import kr210_sim.envs`` registers ``kr210_sim/PickPlace-v0``
(:class:`~kr210_sim.envs.pick_place.PickPlaceEnv`), so::

    import gymnasium as gym
    import kr210_sim.envs

    env = gym.make("kr210_sim/PickPlace-v0", control="cartesian")

or, without the import, ``gym.make("kr210_sim.envs:kr210_sim/PickPlace-v0")`` (Gymnasium
imports the module before the id is looked up). Registration happens on import because
Gymnasium 1.x reads no package entry points (its plugin group was removed in 1.0); the spec
names the environment by a string entry point, so worker processes of
``gymnasium.make_vec(..., vectorization_mode="async")`` build it from the spec alone.

Needs the ``gym`` extra (in a clone: ``pip install '.[gym]'``) (Gymnasium, and h5py for
``python -m kr210_sim demos``).
"""

from __future__ import annotations

try:
    import gymnasium as gym
except ImportError as exc:  # pragma: no cover - depends on the installation
    raise ModuleNotFoundError(
        "kr210_sim.envs needs gymnasium: pip install '.[gym]' (in a clone)", name="gymnasium"
    ) from exc

from kr210_sim.envs.expert import ScriptedExpert
from kr210_sim.envs.pick_place import PickPlaceEnv

__all__ = ["ENV_ID", "PickPlaceEnv", "ScriptedExpert"]

#: The registered id.
ENV_ID = "kr210_sim/PickPlace-v0"

if ENV_ID not in gym.registry:
    gym.register(
        id=ENV_ID,
        entry_point="kr210_sim.envs.pick_place:PickPlaceEnv",
        max_episode_steps=None,  # the environment truncates at its own max_steps
        disable_env_checker=False,
    )
