"""A train job's profile defaults to auto, as `dualsys train`'s does: the vector profile for a vector task,
default for NicoGrasp; an env that cannot be built is accepted (its schema allows it) and fails at the job's
start, naming why."""

from __future__ import annotations

import pytest

from service.execution.job_kinds.train import load_train_config, prepare_train
from service.schemas.specs import TrainSpec


def test_auto_picks_the_profile_by_the_tasks_observations() -> None:
    pendulum = TrainSpec(algo="ddpg", overrides={"env.id": "Pendulum-v1"})
    assert pendulum.profile == "auto"
    config = load_train_config(pendulum)
    assert config.net.encoder == "none" and config.agent.batch_size == 256  # the vector profile
    grasp = load_train_config(TrainSpec(algo="ddpg"))
    assert grasp.net.encoder == "learned" and grasp.agent.batch_size == 64  # the default profile
    named = load_train_config(TrainSpec(algo="ddpg", profile="default", overrides={"env.id": "Pendulum-v1"}))
    assert named.net.encoder == "learned"


def test_an_env_that_cannot_be_built_is_accepted_and_its_job_fails_naming_why() -> None:
    """The schema allows any registered id and any env.kwargs (schemathesis checks that such a spec is
    accepted); auto falls back to the default profile and the run's own env build names the error."""
    from core.envs.gym_env import EnvError
    from core.runs.trainer import make_env

    for overrides, message in (
        ({"env.id": "Pendulum-v1", "env.kwargs": {"no_such_argument": 1}}, r"bad env\.kwargs for Pendulum"),
        ({"env.id": "Ant-v3"}, "cannot build Ant-v3: ImportError"),  # registered; gymnasium raises on build
    ):
        spec = TrainSpec(algo="ddpg", overrides=overrides)
        submission = prepare_train(spec, registry=None)  # type: ignore[arg-type]
        assert submission.resolved["config"]["net"]["encoder"] == "learned"  # the default profile
        with pytest.raises(EnvError, match=message):
            make_env(load_train_config(spec))
