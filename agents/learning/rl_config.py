"""Hyperparameters of `clutter-gym train`, in the conventions of rl-baselines3-zoo: one YAML file
per algorithm (`agents/hyperparams/<algo>.yml`, shipped with the package), one entry per env id.

An entry holds the zoo's own keys (`ZOO_KEYS`: the default budget and number of envs, the
policy, VecNormalize, the env's keywords) and keywords of the algorithm's class, taken from its
signature so that every keyword stable-baselines3 or sb3-contrib accepts is accepted and a typo
is not. An entry may name a `BASE`: another file whose entry for the same env id it overrides
(the configs of the results in `agents/hyperparams/` hold only what differs from the defaults).
A config is checked whole before any training starts: an unknown algorithm, env id or key is one
line that lists the allowed ones.

The RL libraries (the `rl` extra) are imported only when a command needs them, so that the rest
of the command line works without them.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

ALGOS = ("ppo", "sac", "tqc")
HYPERPARAMS = Path(__file__).resolve().parents[1] / "hyperparams"
RL_EXTRA = "install the rl extra: pip install -e '.[rl]'"
ZOO_KEYS = ("n_timesteps", "n_envs", "policy", "normalize", "env_kwargs", "clone_steps")
"""Keys of an entry that are not keywords of the algorithm (rl-baselines3-zoo's names, and
``clone_steps``: the gradient steps of behaviour cloning per env step of a --demos run)."""
BASE = "base"
"""The key naming the file (a path relative to the one holding the entry) whose entry for the
same env id this one overrides: its mappings merged key by key, any other value replaced."""
SET_BY_TRAIN = frozenset(
    ("self", "env", "seed", "verbose", "device", "tensorboard_log", "_init_setup_model")
)
"""The algorithm's keywords that `clutter-gym train` sets itself."""
NOT_IN_YAML = frozenset(("action_noise", "rollout_buffer_class", "rollout_buffer_kwargs"))
"""Keywords that take Python objects a YAML file cannot name."""
NORMALIZE_KEYS = (
    "norm_obs",
    "norm_reward",
    "clip_obs",
    "clip_reward",
    "gamma",
    "epsilon",
    "norm_obs_keys",
)
ACTIVATIONS = {"tanh": "Tanh", "relu": "ReLU", "elu": "ELU", "leaky_relu": "LeakyReLU"}
REPLAY_BUFFERS = ("ReplayBuffer", "HerReplayBuffer")
SCHEDULED = ("learning_rate", "clip_range")
"""Keywords that may be "lin_<value>": a linear decay from value to 0 over the run (the zoo's)."""


@dataclass(frozen=True)
class Hyperparams:
    """One entry of a hyperparameter file, checked; `algo_kwargs` as written (JSON values)."""

    algo: str
    env_id: str
    source: str
    where: str  # how messages name the file: "--config PATH", or the shipped file's path
    policy: str | None  # None: MultiInputPolicy for a Dict observation, else MlpPolicy
    n_timesteps: int | None
    n_envs: int | None
    normalize: dict[str, Any] | None
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    algo_kwargs: dict[str, Any] = field(default_factory=dict)
    clone_steps: int | None = None  # None: `agents.learning.train.CLONE_STEPS`

    def as_dict(self) -> dict[str, Any]:
        """The entry as run.json records it (``clone_steps`` only where the entry sets it, so
        that the runs of entries without it still resume)."""
        own = {} if self.clone_steps is None else {"clone_steps": self.clone_steps}
        return {
            "source": self.source,
            "policy": self.policy,
            "n_timesteps": self.n_timesteps,
            "n_envs": self.n_envs,
            "normalize": self.normalize,
            "env_kwargs": self.env_kwargs,
            **own,
            **self.algo_kwargs,
        }


def require_rl() -> None:
    """ValueError naming the rl extra when one of its packages is missing."""
    try:
        import sb3_contrib  # noqa: F401
        import stable_baselines3  # noqa: F401
        import tensorboard  # noqa: F401
        import yaml  # noqa: F401
    except ImportError as error:
        raise ValueError(f"{error.name} is missing; {RL_EXTRA}") from None


def algorithm_class(algo: str) -> Any:
    """The algorithm's class (stable-baselines3, or sb3-contrib for TQC)."""
    if algo not in ALGOS:
        raise ValueError(f"algo: {algo!r} is unknown; allowed: {', '.join(ALGOS)}")
    try:
        if algo == "tqc":
            from sb3_contrib import TQC

            return TQC
        from stable_baselines3 import PPO, SAC
    except ImportError as error:
        raise ValueError(f"{error.name} is missing; {RL_EXTRA}") from None
    return PPO if algo == "ppo" else SAC


class VecTools(NamedTuple):
    """What a run needs of stable-baselines3's vector envs."""

    make_vec_env: Any
    DummyVecEnv: Any
    SubprocVecEnv: Any
    VecNormalize: Any


def vec_env_tools() -> VecTools:
    try:
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize
    except ImportError as error:
        raise ValueError(f"{error.name} is missing; {RL_EXTRA}") from None
    return VecTools(make_vec_env, DummyVecEnv, SubprocVecEnv, VecNormalize)


def allowed_keys(algo: str) -> tuple[str, ...]:
    """The keys an entry of ``algo`` may hold, sorted."""
    parameters = inspect.signature(algorithm_class(algo).__init__).parameters
    own = set(parameters) - SET_BY_TRAIN - NOT_IN_YAML
    return tuple(sorted(own | set(ZOO_KEYS) | {BASE}))


def default_config(algo: str) -> Path:
    return HYPERPARAMS / f"{algo}.yml"


def read_yaml(path: Path, flag: str) -> dict[str, Any]:
    """The mapping of a YAML file; ValueError naming the flag and the file otherwise."""
    try:
        import yaml
    except ImportError:
        raise ValueError(f"PyYAML is missing; {RL_EXTRA}") from None
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise ValueError(
            f"{flag} {path}: not valid YAML ({' '.join(str(error).split())})"
        ) from None
    except OSError as error:
        raise ValueError(f"{flag} {path}: cannot be read ({error.strerror})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{flag} {path}: expected a mapping of env ids to hyperparameters")
    return data


def load_hyperparams(algo: str, env_id: str, config: Path | None = None) -> Hyperparams:
    """The entry of ``env_id`` in ``config`` (default: the shipped file of ``algo``) over its
    bases, checked."""
    path = config or default_config(algo)
    where = f"--config {path}" if config else str(path)
    entry = _entry(algo, env_id, path, where, "--config", ())
    kwargs = {k: v for k, v in entry.items() if k not in ZOO_KEYS}
    hp = Hyperparams(
        algo=algo,
        env_id=env_id,
        source=str(path),
        where=where,
        policy=_text(entry["policy"], where, env_id, "policy") if "policy" in entry else None,
        n_timesteps=_count(entry.get("n_timesteps"), where, env_id, "n_timesteps"),
        n_envs=_count(entry.get("n_envs"), where, env_id, "n_envs"),
        normalize=_normalize(entry.get("normalize", False), where, env_id),
        env_kwargs=_mapping(entry.get("env_kwargs", {}), where, env_id, "env_kwargs"),
        algo_kwargs=kwargs,
        clone_steps=_count(entry.get("clone_steps"), where, env_id, "clone_steps"),
    )
    algorithm_kwargs(hp)  # names of schedules, activations and buffers are checked now
    return hp


def _entry(
    algo: str, env_id: str, path: Path, where: str, flag: str, overridden_by: tuple[Path, ...]
) -> dict[str, Any]:
    """The entry of ``env_id`` in the file ``path`` (its keys checked) over its `BASE`, if it
    names one; ``flag`` names the file in messages about reading it; ``overridden_by``: the
    files whose entries build on this one."""
    entries = read_yaml(path, flag)
    if env_id not in entries:
        ids = ", ".join(map(str, entries)) or "none"
        raise ValueError(f"{where} has no entry for {env_id}; it has: {ids}")
    entry = entries[env_id]
    if not isinstance(entry, dict):
        raise ValueError(f"{where}: {env_id}: expected a mapping of hyperparameters")
    allowed = allowed_keys(algo)
    for key in entry:
        if key not in allowed:
            raise ValueError(
                f"{where}: {env_id}: unknown key {key!r} for {algo}; allowed: {', '.join(allowed)}"
            )
    if BASE not in entry:
        return entry
    overrides = {k: v for k, v in entry.items() if k != BASE}
    name = _text(entry[BASE], where, env_id, BASE)
    base = (path.parent / name).resolve()
    chain = (*overridden_by, path.resolve())
    if base in chain:
        raise ValueError(f"{where}: {env_id}: {BASE}: {name} is this entry or builds on it")
    flag = f"{where}: {env_id}: {BASE}"
    under = _entry(algo, env_id, base, f"{where}: {BASE} {base}", flag, chain)
    return _merged(under, overrides)


def _merged(base: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """``base`` with ``overrides``: a mapping over a mapping merges key by key (a result's
    env_kwargs keep the entry's), any other value replaces the base's."""
    merged = dict(base)
    for key, value in overrides.items():
        under = merged.get(key)
        if isinstance(under, dict) and isinstance(value, dict):
            value = _merged(under, value)
        merged[key] = value
    return merged


def _text(value: object, where: str, env_id: str, key: str) -> str:
    if not isinstance(value, str):
        raise ValueError(f"{where}: {env_id}: {key}: {value!r} is not a name")
    return value


def _count(value: object, where: str, env_id: str, key: str) -> int | None:
    """An integer >= 1 (the zoo writes budgets as floats: !!float 1e6), or None."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or value != int(value):
        raise ValueError(f"{where}: {env_id}: {key}: {value!r} is not a whole number")
    if value < 1:
        raise ValueError(f"{where}: {env_id}: {key}: {value!r}; must be >= 1")
    return int(value)


def _mapping(value: object, where: str, env_id: str, key: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ValueError(f"{where}: {env_id}: {key}: {value!r} is not a mapping")
    return dict(value)


def _normalize(value: object, where: str, env_id: str) -> dict[str, Any] | None:
    """`normalize`: false, true (VecNormalize's defaults) or a mapping of its keywords."""
    if value is False or value is None:
        return None
    if value is True:
        return {}
    options = _mapping(value, where, env_id, "normalize")
    for key in options:
        if key not in NORMALIZE_KEYS:
            raise ValueError(
                f"{where}: {env_id}: normalize: unknown key {key!r}; "
                f"allowed: {', '.join(NORMALIZE_KEYS)}"
            )
    return options


# --------------------------------------------------------------------------------------------
# YAML values -> the algorithm's keywords
# --------------------------------------------------------------------------------------------
def algorithm_kwargs(hp: Hyperparams) -> dict[str, Any]:
    """The algorithm's keywords: schedules, activation functions and buffer classes by name
    turned into the objects stable-baselines3 takes."""
    kwargs = dict(hp.algo_kwargs)
    for key in SCHEDULED:
        if isinstance(kwargs.get(key), str):
            kwargs[key] = _schedule(kwargs[key], hp, key)
    if "policy_kwargs" in kwargs:
        kwargs["policy_kwargs"] = _policy_kwargs(kwargs["policy_kwargs"], hp)
    if "replay_buffer_class" in kwargs:
        kwargs["replay_buffer_class"] = _replay_buffer(kwargs["replay_buffer_class"], hp)
    if isinstance(kwargs.get("train_freq"), list):
        kwargs["train_freq"] = tuple(kwargs["train_freq"])
    return kwargs


def _schedule(text: str, hp: Hyperparams, key: str) -> Callable[[float], float]:
    prefix, _, number = text.partition("_")
    try:
        initial = float(number)
    except ValueError:
        initial = float("nan")
    if prefix != "lin" or not initial > 0:
        raise ValueError(
            f"{hp.where}: {hp.env_id}: {key}: {text!r}; give a number or 'lin_<number > 0>'"
        )
    return _Linear(initial)


@dataclass(frozen=True)
class _Linear:
    """A linear schedule (picklable, as saved models need): ``initial`` at the start, 0 at the
    end (stable-baselines3 passes the progress remaining, 1 -> 0)."""

    initial: float

    def __call__(self, progress_remaining: float) -> float:
        return progress_remaining * self.initial


def _policy_kwargs(value: object, hp: Hyperparams) -> dict[str, Any]:
    options = _mapping(value, hp.where, hp.env_id, "policy_kwargs")
    activation = options.get("activation_fn")
    if activation is not None:
        if activation not in ACTIVATIONS:
            raise ValueError(
                f"{hp.where}: {hp.env_id}: policy_kwargs.activation_fn: {activation!r}; "
                f"allowed: {', '.join(ACTIVATIONS)}"
            )
        try:
            import torch
        except ImportError:
            raise ValueError(f"torch is missing; {RL_EXTRA}") from None
        options["activation_fn"] = getattr(torch.nn, ACTIVATIONS[activation])
    return options


def _replay_buffer(name: object, hp: Hyperparams) -> Any:
    if name not in REPLAY_BUFFERS:
        raise ValueError(
            f"{hp.where}: {hp.env_id}: replay_buffer_class: {name!r}; "
            f"allowed: {', '.join(REPLAY_BUFFERS)}"
        )
    try:
        from stable_baselines3 import HerReplayBuffer
        from stable_baselines3.common.buffers import ReplayBuffer
    except ImportError:
        raise ValueError(f"stable-baselines3 is missing; {RL_EXTRA}") from None
    return HerReplayBuffer if name == "HerReplayBuffer" else ReplayBuffer
