"""clutter-gym: HERB retrieving objects from clutter under pose uncertainty (pybullet + Gymnasium).

Importing the package registers `ClutterRetrieve-v0`; make it with
`gymnasium.make("ClutterRetrieve-v0", control_mode="trajectory" | "ee_delta", ...)`.
"""

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

ENV_IDS = ("ClutterRetrieve-v0",)

if "ClutterRetrieve-v0" not in registry:
    register(id="ClutterRetrieve-v0", entry_point="clutter_gym.env:ClutterRetrieveEnv")
