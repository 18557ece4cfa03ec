"""clutter-gym: HERB retrieving objects from clutter under pose uncertainty (pybullet + Gymnasium).

Importing the package registers one Gymnasium id per variant (as panda-gym and
Gymnasium-Robotics do), each with its `max_episode_steps`; truncation is Gymnasium's TimeLimit:

- `ClutterRetrieve-v0`: one step executes a whole trajectory (`clutter_gym.env.ClutterRetrieveEnv`);
- `ClutterRetrieveEE-v0`: end-effector steps, sparse reward, goal-conditioned (GoalEnv);
- `ClutterRetrieveEEDense-v0`: the same with the dense (potential-shaped) reward;
- `ClutterRetrieveEEGrasp-v0`: end-effector steps whose goal is the grasp (the hand around the
  goal object, held by two fingers), the first stage of learning the retrieval;
- `ClutterRetrieveEELift-v0`: `ClutterRetrieveEE-v0` with half of the episodes starting with the
  goal object in the hand, gripped by a planned side grasp executed in physics at reset
  (`agents.learning.lift_env`), the second stage;
- `ClutterRetrievePrimitive-v0`: one step is one of the paper's parameterised primitives
  (push-grasp, sweep, PickUp), built by the planner's action code (`agents.learning.primitive_env`).
"""

from gymnasium.envs.registration import register, registry

__version__ = "0.1.0"

# id: (entry point, keywords, max_episode_steps). Variants defined above this package (e.g. an
# action-primitive variant in agents/) are registered here too, by their entry-point string, so
# that `import clutter_gym` registers every id without importing the layers above it.
_VARIANTS: dict[str, tuple[str, dict[str, object], int]] = {
    "ClutterRetrieve-v0": ("clutter_gym.env:ClutterRetrieveEnv", {}, 10),
    "ClutterRetrieveEE-v0": (
        "clutter_gym.env:ClutterRetrieveEEEnv",
        {"reward_type": "sparse"},
        100,
    ),
    "ClutterRetrieveEEDense-v0": (
        "clutter_gym.env:ClutterRetrieveEEEnv",
        {"reward_type": "dense"},
        100,
    ),
    "ClutterRetrieveEEGrasp-v0": (
        "clutter_gym.env:ClutterRetrieveEEEnv",
        {"reward_type": "sparse", "objective": "grasp"},
        100,
    ),
    "ClutterRetrieveEELift-v0": (
        "agents.learning.lift_env:ClutterRetrieveLiftEnv",
        {"reward_type": "sparse", "grasped_start": 0.5},
        100,
    ),
    "ClutterRetrievePrimitive-v0": (
        "agents.learning.primitive_env:ClutterRetrievePrimitiveEnv",
        {},
        6,
    ),
}
ENV_IDS = tuple(_VARIANTS)
"""Every registered id (the tests run the Gymnasium and stable-baselines3 checkers on each)."""

for _id, (_entry_point, _kwargs, _max_steps) in _VARIANTS.items():
    if _id not in registry:
        register(id=_id, entry_point=_entry_point, kwargs=_kwargs, max_episode_steps=_max_steps)
