"""A train job's profile defaults to auto, as `dualsys train`'s does: the vector profile for a vector task,
default for NicoGrasp; an env that cannot be built is refused at submission, naming the spec."""

from __future__ import annotations

import pytest

from service.errors import SpecRejected
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


def test_an_env_that_cannot_be_built_is_refused_at_submission() -> None:
    spec = TrainSpec(algo="ddpg", overrides={"env.id": "Pendulum-v1", "env.kwargs": {"no_such_argument": 1}})
    with pytest.raises(SpecRejected, match=r"bad env\.kwargs for Pendulum-v1"):
        prepare_train(spec, registry=None)  # type: ignore[arg-type]
