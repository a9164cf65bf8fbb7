"""`dualsys train`: one-line errors with exit code 2, a tiny run with --json, resume."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from dualsys_cli.main import app

TINY = [
    "--set",
    "net.conv_channels=4,4",
    "--set",
    "net.latent_dim=8",
    "--set",
    "env.max_steps=6",
    "--set",
    "agent.batch_size=8",
    "--set",
    "agent.learning_starts=6",
    "--set",
    "run.eval_episodes=2",
    "--set",
    "agent.buffer_size=300",
]


def invoke(*args: str):
    return CliRunner().invoke(app, ["train", *args])


def test_bad_algo_is_one_line_and_exit_2(tmp_path):
    result = invoke("--algo", "nonsense", "--episodes", "1", "--out", str(tmp_path / "r"))
    assert result.exit_code == 2
    assert result.stderr.strip().count("\n") == 0 and "unknown algo 'nonsense'" in result.stderr
    assert "Traceback" not in result.output
    assert not (tmp_path / "r").exists()


def test_bad_set_is_one_line_and_exit_2(tmp_path):
    for bad, fragment in (
        ("agent.nope=3", "agent.nope"),
        ("agent.batch_size=many", "agent.batch_size"),
        ("nokey", "nokey"),
    ):
        result = invoke("--set", bad, "--episodes", "1", "--out", str(tmp_path / "r"))
        assert result.exit_code == 2, bad
        assert result.stderr.strip().count("\n") == 0 and fragment in result.stderr
    assert invoke("--reward", "medium", "--episodes", "1").exit_code == 2
    assert invoke("--profile", "huge", "--episodes", "1").exit_code == 2
    assert invoke("--resume", str(tmp_path / "nothing")).exit_code == 2


def test_tiny_run_prints_one_json_line_and_resumes(tmp_path):
    out = tmp_path / "run"
    result = invoke(
        "--algo",
        "cacla",
        "--reward",
        "sparse",
        "--episodes",
        "3",
        "--seed",
        "4",
        "--out",
        str(out),
        "--json",
        *TINY,
    )
    assert result.exit_code == 0, result.output
    line = result.stdout.strip()
    assert line.count("\n") == 0
    summary = json.loads(line)
    assert set(summary) == {"run_dir", "episodes", "steps", "final_perf", "auc", "success_rate", "wall_s"}
    assert summary["episodes"] == 3 and summary["run_dir"] == str(out)
    assert "seed: 4" in (out / "config.yaml").read_text() and "ac: cacla" in (out / "config.yaml").read_text()
    again = invoke("--resume", str(out), "--episodes", "5", "--json")
    assert again.exit_code == 0, again.output
    assert json.loads(again.stdout)["episodes"] == 5
    assert invoke("--out", str(out), "--episodes", "1").exit_code == 2  # existing run, no --resume


def test_profile_auto_picks_the_vector_profile_for_vector_tasks_only(tmp_path):
    from dualsys_cli.train import build_config

    common = dict(config_file=None, resume=None, algo="sac", ac=None, reward=None, seed=None, episodes=None,
                  steps=None, minutes=None)
    vector = build_config(profile="auto", overrides=["agent.batch_size=32"], env="Pendulum-v1", **common)
    assert vector.net.encoder == "none" and vector.agent.warmup == "uniform"
    assert vector.agent.batch_size == 32  # --set still wins over the profile
    image = build_config(profile="auto", overrides=[], env=None, **common)
    assert image.net.encoder == "learned" and image.agent.warmup == "policy"
    explicit = build_config(profile="default", overrides=[], env="Pendulum-v1", **common)
    assert explicit.net.encoder == "learned"
