"""Importing this module registers every registered task with gymnasium.

    import gymnasium as gym
    import pipette_cli.envs  # noqa: F401
    env = gym.make("pipette/PickUpTestTube-v1")

or, without the import: ``gym.make("pipette_cli.envs:pipette/PickUpTestTube-v1")``.
"""

from pipette_cli.sim.gym_env import PipetteGymEnv, register_envs

register_envs()

__all__ = ["PipetteGymEnv"]
