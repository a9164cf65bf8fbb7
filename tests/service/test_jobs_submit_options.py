"""`dualsys jobs submit train` takes `dualsys train`'s options (its help says so): every option of `train`
but the short, documented list `TRAIN_ONLY` exists in `submit train` under the same name and of the same
kind (flag or value), read from the two Click commands Typer builds; and the shared options that are not a
spec field (--env, --config, --tensorboard) reach the spec as the overrides `dualsys train` would apply."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import typer
from typer.testing import CliRunner

from dualsys_cli import jobs
from dualsys_cli.main import app

SUBMIT_ONLY = {"--url"}
"""What `submit train` adds: the service to send the job to."""


def _subcommand(group: Any, *path: str) -> Any:
    """The Click command at `path` under `group` (Typer's groups are Click groups, or its vendored ones)."""
    command = group
    for name in path:
        command = command.get_command(type(command).context_class(command), name)
        assert command is not None, f"no command {' '.join(path)}"
    return command


def _commands() -> tuple[Any, Any]:
    root = typer.main.get_command(app)
    return _subcommand(root, "train"), _subcommand(root, "jobs", "submit", "train")


def _options(command: Any) -> dict[str, Any]:
    """Every option name (`--tensorboard` and `--no-tensorboard` alike) → its parameter; --help aside."""
    found: dict[str, Any] = {}
    for param in command.params:
        if param.param_type_name == "option":
            for name in (*param.opts, *param.secondary_opts):
                found[name] = param
    return found


def _value_type(option: Any) -> str:
    """The option's value type as its annotation says (Typer's vendored Click keeps it there)."""
    descriptor = getattr(option, "type_descriptor", None)
    if descriptor is not None:
        return str(descriptor.annotation)
    return str(option.type.name)  # plain Click


def test_submit_train_takes_every_option_of_train_but_the_documented_ones() -> None:
    train, submit = _commands()
    train_options, submit_options = _options(train), _options(submit)
    only_train = set(jobs.TRAIN_ONLY)
    assert only_train <= set(train_options), f"TRAIN_ONLY names options train does not have: {only_train}"
    shared = set(train_options) - only_train
    missing = sorted(shared - set(submit_options))
    assert not missing, f"`dualsys jobs submit train` lacks train's {missing}"
    assert set(submit_options) - set(train_options) == SUBMIT_ONLY
    for name in sorted(shared):
        ours, theirs = submit_options[name], train_options[name]
        assert ours.is_flag == theirs.is_flag, f"{name}: a flag in one command, a value in the other"
        assert ours.multiple == theirs.multiple, f"{name}: repeatable in one command only"
        ours_type, theirs_type = _value_type(ours), _value_type(theirs)
        assert ours_type == theirs_type, f"{name}: {ours_type} here, {theirs_type} in train"
    # the help says which options are train's own
    help_text = " ".join((submit.help or "").split())
    assert all(name in help_text for name in only_train), help_text
    assert all(name in " ".join((jobs.__doc__ or "").split()) for name in ("--env", "TRAIN_ONLY"))


@pytest.fixture()
def sent(monkeypatch: pytest.MonkeyPatch) -> list[dict[str, Any]]:
    """The specs `submit train` would send (no service needed)."""
    specs: list[dict[str, Any]] = []
    monkeypatch.setattr(
        jobs, "_submit", lambda url, kind, spec, as_json: specs.append({"kind": kind, **spec})
    )
    return specs


def test_env_config_and_tensorboard_reach_the_spec_as_train_applies_them(
    sent: list[dict[str, Any]], tmp_path: Path
) -> None:
    config = tmp_path / "tiny.yaml"
    config.write_text(
        "agent:\n  batch_size: 16\n  ac: sac\nnet:\n  conv_channels: [4, 4]\nrun:\n  episodes: none\n"
    )
    result = CliRunner().invoke(
        app,
        [
            "jobs", "submit", "train",
            "--env", "MountainCarContinuous-v0",
            "--algo", "im2c",
            "--ac", "sac",
            "--steps", "5000",
            "--config", str(config),
            "--set", "agent.batch_size=32",  # --set after --config, as in train
            "--set", "env.id=Pendulum-v1",  # --env after --set, as in train
            "--tensorboard",
        ],
    )
    assert result.exit_code == 0, result.output
    (spec,) = sent
    assert (spec["kind"], spec["algo"], spec["ac"], spec["steps"]) == ("train", "im2c", "sac", 5000)
    assert spec["overrides"] == {
        "agent.batch_size": 32,
        "agent.ac": "sac",
        "net.conv_channels": [4, 4],
        "run.episodes": None,
        "env.id": "MountainCarContinuous-v0",
        "run.tensorboard": True,
    }


def test_a_missing_config_file_is_one_line(sent: list[dict[str, Any]], tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["jobs", "submit", "train", "--config", str(tmp_path / "none.yaml")])
    assert result.exit_code == 2 and "config file not found" in result.output and not sent
