"""Settings (env prefix, bind rule), spec → config mapping, and kinds whose library is missing."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from service.schemas.specs import ExportSpec, TrainSpec
from service.settings import InsecureBindError, ServiceSettings, is_loopback


def test_settings_read_the_dualsys_prefix(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DUALSYS_WORKERS", "3")
    monkeypatch.setenv("DUALSYS_DATABASE_URL", "postgresql://u@db/dualsys")
    monkeypatch.setenv("DUALSYS_TOKEN", "s3cret")
    settings = ServiceSettings()
    assert settings.workers == 3 and settings.database_url == "postgresql://u@db/dualsys"
    assert settings.token is not None and settings.token.get_secret_value() == "s3cret"
    assert "s3cret" not in repr(settings)


@pytest.mark.parametrize("host", ["127.0.0.1", "127.8.0.1", "localhost", "::1", "[::1]"])
def test_loopback_hosts(host: str) -> None:
    assert is_loopback(host)
    ServiceSettings(host=host, token=None).check_bind()


@pytest.mark.parametrize("host", ["0.0.0.0", "192.168.1.10", "::", "example.org"])
def test_non_loopback_bind_needs_a_token(host: str) -> None:
    with pytest.raises(InsecureBindError, match="DUALSYS_TOKEN"):
        ServiceSettings(host=host, token=None).check_bind()
    ServiceSettings(host=host, token="t").check_bind()


def test_train_spec_maps_to_config_overrides_like_the_cli() -> None:
    spec = TrainSpec(algo="ddpg", reward="sparse", seed=4, steps=500, overrides={"agent.batch_size": 32})
    assert spec.config_overrides() == [
        "agent.batch_size=32",
        "run.algo=ddpg",
        "env.reward_mode=sparse",
        "run.seed=4",
        "run.steps=500",
        "run.episodes=none",
    ]
    with pytest.raises(ValidationError, match="unknown config key"):
        TrainSpec(overrides={"agent.nope": 1})
    with pytest.raises(ValidationError):
        ExportSpec(policy="p@1", out="sub/x.onnx")



def test_only_a_resume_checkpoint_makes_a_job_resumable(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from service.execution.job_kinds.catalogue import can_resume, job_kind

    (tmp_path / "checkpoints").mkdir()
    (tmp_path / "checkpoints" / "best.pt").write_bytes(b"x")
    (tmp_path / "metrics.csv").write_text("episode\n1\n")
    assert not can_resume(job_kind("train"), tmp_path)  # best.pt alone: the trainer cannot resume
    (tmp_path / "checkpoints" / "latest.pt").write_bytes(b"x")
    assert can_resume(job_kind("train"), tmp_path)
    assert not can_resume(job_kind("eval"), tmp_path)
    assert not can_resume(job_kind("probe"), tmp_path)
