"""RL Baselines3 Zoo's published hyperparameters for a task, as Stable-Baselines3 constructor arguments.

Source: the ``rl-zoo3`` package (pinned in the ``bench`` extra), its data files
``rl_zoo3/hyperparams/{sac,td3,ddpg}.yml``, read with :mod:`importlib.resources` from a module object made
from the package's spec and never executed: ``import rl_zoo3`` would replace gymnasium's ``TimeLimit``
process-wide (``rl_zoo3/gym_patches.py``) and import optuna, huggingface_hub and sb3-contrib. No number is
copied by hand. The translation follows the same release's ``rl_zoo3/exp_manager.py``
(``ExperimentManager._preprocess_hyperparams``, ``_preprocess_schedules``, ``_preprocess_action_noise``,
``_preprocess_normalization``) and ``read_hyperparameters`` (the entry is looked up by the exact gymnasium
id; the ``default`` entry is never a fallback):

* ``n_timesteps`` — not used: a cell's budget is ``run.steps``. Recorded under ``unused``.
* ``policy`` — ``MlpPolicy`` for vector observations, ``CnnPolicy`` for images; anything else (or a policy
  that does not fit the adapted observations) is refused.
* ``learning_rate`` — a number, or ``lin_<x>``: linear from x to 0 over training (the zoo's
  ``SimpleLinearSchedule``), as SB3's ``LinearSchedule(x, 0, 1)``, which also gives 0 past the end. SB3 feeds
  a schedule ``progress_remaining = 1 − num_timesteps / _total_timesteps``; the SB3 peer sets
  ``_total_timesteps`` to ``run.steps``, so the schedule runs over our budget, not the zoo's ``n_timesteps``.
* ``noise_type`` / ``noise_std`` — ``normal`` → ``NormalActionNoise(0, σ)``, ``ornstein-uhlenbeck`` →
  ``OrnsteinUhlenbeckActionNoise(0, σ)`` (SB3's θ = 0.15, dt = 0.01), one σ per action dimension.
* ``policy_kwargs`` — a string in the yml (``"dict(log_std_init=-3.67, net_arch=[64, 64])"``) that the zoo
  ``eval``s; here it is parsed with :mod:`ast` and only literals are accepted (numbers, strings, booleans,
  None, lists, tuples, ``{...}`` and ``dict(...)`` of those); a name such as ``nn.ReLU`` is refused.
* ``train_freq`` — an int, or ``[n, "step"|"episode"]`` → a tuple, as the zoo does.
* every other key that is a parameter of the algorithm's constructor (``buffer_size``, ``batch_size``,
  ``learning_starts``, ``gamma``, ``tau``, ``gradient_steps``, ``ent_coef``, ``use_sde``,
  ``use_sde_at_warmup``, ``sde_sample_freq``, ``target_entropy``, ...) — passed as it is.
* refused, with a one-line :class:`ExperimentError`: ``normalize`` (VecNormalize: not implemented — its
  running statistics would have to be checkpointed with the model, applied to the greedy evaluations and
  kept out of the logged returns; in 2.9.2 the sac/td3/ddpg entries with ``normalize`` also need a wrapper,
  HER or the PyBullet envs, which are refused or absent anyway), ``env_wrapper``, ``vec_env_wrapper``,
  ``frame_stack``, ``callback``, ``replay_buffer_class``/``replay_buffer_kwargs`` (HER), ``n_envs`` other
  than 1, ``monitor_kwargs`` and ``env_kwargs``.

Env adaptation: the SB3 peer trains on ``core.envs.gym_env.make_env``'s env, whose actions are already
rescaled to [-1, 1]; SB3 scales actions to [-1, 1] itself and adds the noise there, so an agent on the
rescaled env acts exactly as one on the raw env (Pendulum-v1's ±2 included).
"""

from __future__ import annotations

import ast
import importlib.metadata
import importlib.resources
import importlib.util
import inspect
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import yaml

from core.experiments.spec import ExperimentError

ZOO_DISTRIBUTION = "rl-zoo3"
"""The PyPI name of RL Baselines3 Zoo (``pip install 'dualsys[bench]'`` installs the pinned release)."""

ZOO_ALGOS: tuple[str, ...] = ("sac", "td3", "ddpg")
"""The zoo's hyperparameter files the SB3 peers read (``rl_zoo3/hyperparams/<algo>.yml``)."""

UNUSED_KEYS: dict[str, str] = {"n_timesteps": "the budget is run.steps"}
"""Zoo keys that are recorded but not used, and why."""

REFUSED_KEYS: dict[str, str] = {
    "normalize": "VecNormalize is not implemented for the SB3 peers",
    "env_wrapper": "env wrappers are not applied",
    "vec_env_wrapper": "VecEnv wrappers are not applied",
    "frame_stack": "frame stacking is not applied",
    "callback": "zoo callbacks are not run",
    "replay_buffer_class": "only SB3's default replay buffer is supported (no HER)",
    "replay_buffer_kwargs": "only SB3's default replay buffer is supported (no HER)",
    "monitor_kwargs": "the run directory records episodes itself",
    "env_kwargs": "env keyword arguments come from the experiment's env_kwargs",
}
"""Zoo keys the SB3 peers refuse, and why (``n_envs`` is refused unless it is 1)."""

SPECIAL_KEYS: frozenset[str] = frozenset(
    {"policy", "learning_rate", "noise_type", "noise_std", "policy_kwargs", "train_freq", "n_envs"}
)
"""Zoo keys translated here rather than passed to the constructor as they are."""

_NOT_FROM_ZOO: frozenset[str] = frozenset(
    {"self", "policy", "env", "seed", "device", "verbose", "tensorboard_log", "_init_setup_model"}
    | {"action_noise"}
)
"""Constructor parameters a zoo entry may not set (the run sets them)."""

NOISE_CLASSES: dict[str, str] = {
    "normal": "NormalActionNoise",
    "ornstein-uhlenbeck": "OrnsteinUhlenbeckActionNoise",
}
"""The zoo's ``noise_type`` → the ``stable_baselines3.common.noise`` class."""


def missing_zoo_message(name: str) -> str:
    return f"{name} with agent.sb3_hyperparams=zoo needs RL Baselines3 Zoo: pip install 'dualsys[bench]'"


def zoo_version() -> str:
    """The installed rl-zoo3 release (ExperimentError when it is not installed)."""
    try:
        return importlib.metadata.version(ZOO_DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        raise ExperimentError(missing_zoo_message("an SB3 peer")) from None


def hyperparams_file(algo: str) -> Any:
    """``rl_zoo3/hyperparams/<algo>.yml`` of the installed package as an ``importlib.resources`` Traversable,
    without executing ``rl_zoo3/__init__.py`` (see the module docstring)."""
    if algo not in ZOO_ALGOS:
        raise ExperimentError(f"RL Zoo hyperparameters are read for {', '.join(ZOO_ALGOS)}, not {algo!r}")
    spec = importlib.util.find_spec("rl_zoo3")
    if spec is None:
        raise ExperimentError(missing_zoo_message(f"sb3-{algo}"))
    package = importlib.util.module_from_spec(spec)  # a module object for its resources; not executed
    return importlib.resources.files(package) / "hyperparams" / f"{algo}.yml"


def zoo_table(algo: str) -> dict[str, dict[str, Any]]:
    """Every entry of the zoo's ``<algo>.yml``: gymnasium id → its hyperparameters, as the yml gives them."""
    return yaml.safe_load(hyperparams_file(algo).read_text())


def zoo_entry(algo: str, env_id: str) -> dict[str, Any]:
    """The zoo's ``<algo>`` entry for ``env_id``, checked (every key is one this module translates);
    a one-line ExperimentError naming the algo and the id when there is none or it cannot be translated."""
    table = zoo_table(algo)
    if env_id not in table:
        ids = sorted(key for key in table if key not in ("default", "atari"))
        raise ExperimentError(
            f"RL Zoo {zoo_version()} has no {algo} hyperparameters for {env_id!r} "
            f"(rl_zoo3/hyperparams/{algo}.yml has {', '.join(ids)})"
        )
    entry = dict(table[env_id])
    where = f"RL Zoo's {algo} entry for {env_id}"
    for key, value in entry.items():
        if key in REFUSED_KEYS:
            shown = f"{key}: {value!r}" if len(repr(value)) <= 60 else key
            raise ExperimentError(f"{where} sets {shown}, which is refused: {REFUSED_KEYS[key]}")
    if int(entry.get("n_envs", 1)) != 1:
        raise ExperimentError(f"{where} trains on n_envs: {entry['n_envs']}; the SB3 peers run one env")
    parameters = _constructor_parameters(algo)
    for key in entry:
        if key not in SPECIAL_KEYS and key not in UNUSED_KEYS and key not in parameters:
            raise ExperimentError(f"{where} sets {key!r}, which SB3's {algo.upper()} does not take")
    try:
        if isinstance(entry.get("policy_kwargs"), str):
            parse_policy_kwargs(entry["policy_kwargs"])
        _learning_rate(entry.get("learning_rate"))
        _noise_class(entry)
    except ValueError as error:
        raise ExperimentError(f"{where}: {error}") from None
    return entry


def _constructor_parameters(algo: str) -> frozenset[str]:
    import stable_baselines3

    cls = getattr(stable_baselines3, algo.upper())
    return frozenset(inspect.signature(cls.__init__).parameters) - _NOT_FROM_ZOO


# -- policy_kwargs: literals only ---------------------------------------------------------------


def parse_policy_kwargs(text: str) -> dict[str, Any]:
    """The zoo's ``policy_kwargs`` string as a dict of literals, parsed with :mod:`ast` (never ``eval``):
    ``"dict(log_std_init=-3.67, net_arch=[64, 64], use_expln=True)"`` →
    ``{"log_std_init": -3.67, "net_arch": [64, 64], "use_expln": True}``. ValueError (one line) otherwise."""
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        raise ValueError(f"policy_kwargs {text!r} is not a Python expression") from None
    value = _literal(tree.body, text)
    if not isinstance(value, dict):
        raise ValueError(f"policy_kwargs {text!r} is not a dict")
    return value


def _literal(node: ast.AST, text: str) -> Any:
    if isinstance(node, ast.Constant) and isinstance(node.value, int | float | str | bool | type(None)):
        return node.value
    if (
        isinstance(node, ast.UnaryOp)
        and isinstance(node.op, ast.USub | ast.UAdd)
        and isinstance(node.operand, ast.Constant)
        and isinstance(node.operand.value, int | float)
        and not isinstance(node.operand.value, bool)
    ):
        return -node.operand.value if isinstance(node.op, ast.USub) else node.operand.value
    if isinstance(node, ast.List):
        return [_literal(item, text) for item in node.elts]
    if isinstance(node, ast.Tuple):
        return tuple(_literal(item, text) for item in node.elts)
    if isinstance(node, ast.Dict) and all(key is not None for key in node.keys):
        keys = [_literal(key, text) for key in node.keys if key is not None]
        if all(isinstance(key, str) for key in keys):
            return dict(zip(keys, (_literal(value, text) for value in node.values), strict=True))
    if (
        isinstance(node, ast.Call)
        and isinstance(node.func, ast.Name)
        and node.func.id == "dict"
        and not node.args
        and all(keyword.arg is not None for keyword in node.keywords)
    ):
        return {str(keyword.arg): _literal(keyword.value, text) for keyword in node.keywords}
    raise ValueError(
        f"policy_kwargs {text!r}: {ast.unparse(node)!r} is not a literal "
        "(numbers, strings, booleans, None, lists, tuples and dict(...) are read)"
    )


# -- the translation ----------------------------------------------------------------------------


def _learning_rate(value: Any) -> float | tuple[str, float] | None:
    """A float, ``("linear", x)`` for ``lin_<x>``, or None (SB3's default)."""
    if value is None:
        return None
    if isinstance(value, bool):
        raise ValueError(f"learning_rate {value!r} is not a number or lin_<x>")
    if isinstance(value, int | float):
        return float(value)
    if isinstance(value, str) and value.startswith("lin_"):
        try:
            return ("linear", float(value[len("lin_") :]))
        except ValueError:
            pass
    raise ValueError(f"learning_rate {value!r} is not a number or lin_<x>")


def _noise_class(entry: dict[str, Any]) -> str | None:
    noise_type = entry.get("noise_type")
    if noise_type is None:
        return None
    name = str(noise_type).strip()
    if name not in NOISE_CLASSES:
        raise ValueError(f"noise_type {noise_type!r} (known: {', '.join(NOISE_CLASSES)})")
    if "noise_std" not in entry:
        raise ValueError(f"noise_type {noise_type!r} without noise_std")
    return NOISE_CLASSES[name]


@dataclass
class ZooSettings:
    """A zoo entry translated: SB3's ``policy`` and constructor arguments, and where they came from."""

    algo: str
    env_id: str
    version: str
    entry: dict[str, Any]
    """The entry as the yml gives it."""
    policy: str
    kwargs: dict[str, Any] = field(default_factory=dict)
    """Constructor arguments (SB3 objects: schedules, action noise)."""
    unused: dict[str, Any] = field(default_factory=dict)
    """Zoo keys recorded but not used (``n_timesteps``)."""

    @property
    def source(self) -> str:
        return f"{ZOO_DISTRIBUTION} {self.version}: rl_zoo3/hyperparams/{self.algo}.yml, {self.env_id}"


def zoo_settings(algo: str, env_id: str, *, action_dim: int, obs_kind: str) -> ZooSettings:
    """The zoo's ``<algo>`` hyperparameters for ``env_id`` as SB3 arguments (see the module docstring) for an
    env with ``action_dim`` actions and ``obs_kind`` (``vector`` | ``image``) observations."""
    from stable_baselines3.common import noise
    from stable_baselines3.common.utils import LinearSchedule

    entry = zoo_entry(algo, env_id)
    policy = str(entry.get("policy", "MlpPolicy"))
    wanted = {"vector": "MlpPolicy", "image": "CnnPolicy"}[obs_kind]
    if policy != wanted:
        raise ExperimentError(
            f"RL Zoo's {algo} entry for {env_id} uses {policy}; {obs_kind} observations need {wanted}"
        )
    kwargs: dict[str, Any] = {}
    unused: dict[str, Any] = {}
    for key, value in entry.items():
        if key in UNUSED_KEYS:
            unused[key] = value
        elif key not in SPECIAL_KEYS:
            kwargs[key] = value
    rate = _learning_rate(entry.get("learning_rate"))
    if isinstance(rate, tuple):
        kwargs["learning_rate"] = LinearSchedule(rate[1], 0.0, 1.0)
    elif rate is not None:
        kwargs["learning_rate"] = rate
    if "train_freq" in entry:
        frequency = entry["train_freq"]
        kwargs["train_freq"] = tuple(frequency) if isinstance(frequency, list) else int(frequency)
    if "policy_kwargs" in entry:
        raw = entry["policy_kwargs"]
        kwargs["policy_kwargs"] = parse_policy_kwargs(raw) if isinstance(raw, str) else dict(raw)
    noise_class = _noise_class(entry)
    if noise_class is not None:
        sigma = float(entry["noise_std"]) * np.ones(action_dim)
        kwargs["action_noise"] = getattr(noise, noise_class)(mean=np.zeros(action_dim), sigma=sigma)
    return ZooSettings(
        algo=algo,
        env_id=env_id,
        version=zoo_version(),
        entry=entry,
        policy=policy,
        kwargs=kwargs,
        unused=unused,
    )
