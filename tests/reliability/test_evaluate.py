"""agents.evaluate never reports a silently wrong number and never throws results away
(items 6, 7 and 9).

The pretrained Detumble policy stands in for any trained model: it is only good with its
``VecNormalize`` statistics, so evaluating it without them shows."""

from __future__ import annotations

import json
import pickle
import shutil
from pathlib import Path

import pytest
from reliability_helpers import ROOT, assert_one_line_error, run_module

import agents.evaluate as ev
from agents.evaluate import EvaluationError, evaluate, find_normalization, read_sidecar

PRETRAINED = ROOT / "agents" / "pretrained"
DETUMBLE = "RigidEnv/Detumble-v0"
ERR = "agents.evaluate: error: "
EPISODES, SEED = 8, 4242


def _copy_model(
    folder: Path, name: str, stats: str | None, sidecar: dict | None, task: str = "detumble"
) -> Path:
    """A pretrained policy as ``folder/name`` with its statistics under ``stats`` and a
    sidecar as agents.train writes it (``None``: no sidecar, as a foreign model)."""
    folder.mkdir(parents=True, exist_ok=True)
    model = folder / name
    shutil.copy(PRETRAINED / f"ppo_{task}.zip", model)
    if stats is not None:
        shutil.copy(PRETRAINED / f"ppo_{task}_vecnormalize.pkl", folder / stats)
    if sidecar is not None:
        model.with_suffix(".json").write_text(json.dumps(sidecar))
    return model


def _sidecar(stats: str | None, **changes: object) -> dict:
    return {"env_id": DETUMBLE, "algo": "ppo", "env_kwargs": {}, "vecnormalize": stats, **changes}


@pytest.fixture(scope="module")
def reference() -> dict:
    """The pretrained policy with its statistics, as shipped."""
    return evaluate(PRETRAINED / "ppo_detumble.zip", DETUMBLE, EPISODES, SEED, only=["model"])


@pytest.mark.parametrize(
    ("where", "stats", "sidecar"),
    [
        ("eval/best_model.zip", "best_model_vecnormalize.pkl", True),
        ("checkpoints/model_4096_steps.zip", "model_vecnormalize_4096_steps.pkl", True),
        ("checkpoints/model_4096_steps.zip", "model_vecnormalize_4096_steps.pkl", False),
        ("model.zip", "vecnormalize.pkl", True),
    ],
)
def test_statistics_are_found_for_every_model_a_run_writes(
    tmp_path, reference, where, stats, sidecar
):
    """Item 6. The best model and a checkpoint (with the sidecar agents.train writes, or the
    SB3 checkpoint names alone) are evaluated with their statistics: the same numbers as the
    shipped policy, not those of raw observations."""
    model = _copy_model(
        tmp_path / Path(where).parent, Path(where).name, stats, _sidecar(stats) if sidecar else None
    )
    assert find_normalization(model, read_sidecar(model)) == model.parent / stats
    assert evaluate(model, DETUMBLE, EPISODES, SEED, only=["model"]) == reference


@pytest.mark.slow
def test_without_statistics_it_is_an_error_or_a_warning(tmp_path, capsys):
    """Item 6. A sidecar that names missing statistics is an error; a foreign model without
    any is evaluated on raw observations with a warning line. The issue's case shows why:
    Reorient's policy is far worse without its statistics (0.04 against 0.59 on 100
    episodes), so that must never happen silently."""
    named = _copy_model(tmp_path / "a", "best_model.zip", None, _sidecar("best_model_stats.pkl"))
    with pytest.raises(EvaluationError, match=r"best_model_stats\.pkl: missing"):
        evaluate(named, DETUMBLE, EPISODES, SEED, only=["model"])
    reorient = "RigidEnv/Reorient-v1"
    foreign = _copy_model(tmp_path / "b", "best_model.zip", None, None, task="reorient")
    raw = evaluate(foreign, reorient, EPISODES, SEED, only=["model"])["model"]
    assert "evaluating on raw observations" in capsys.readouterr().err
    shipped = evaluate(PRETRAINED / "ppo_reorient.zip", reorient, EPISODES, SEED, ["model"])
    assert raw["success_rate"] < shipped["model"]["success_rate"]


@pytest.mark.slow
def test_recorded_env_kwargs_are_honoured_and_merged(tmp_path):
    """Item 6/7. The sidecar's env_kwargs are the env the model is evaluated on (and so the
    controllers beside it); --env-kwargs merges over them key by key."""
    recorded = {"integrator": "rk4", "randomization": {"mass": 0.1}}
    model = _copy_model(
        tmp_path, "m.zip", "m_vecnormalize.pkl", _sidecar("m_vecnormalize.pkl", env_kwargs=recorded)
    )
    extra = {"randomization": {"inertia": 0.2}}
    merged = {"integrator": "rk4", "randomization": {"mass": 0.1, "inertia": 0.2}}
    got = evaluate(model, DETUMBLE, EPISODES, SEED, only=["model", "pd"], env_kwargs=extra)
    plain = _copy_model(tmp_path / "plain", "m.zip", "m_vecnormalize.pkl", None)
    want = evaluate(plain, DETUMBLE, EPISODES, SEED, only=["model", "pd"], env_kwargs=merged)
    assert got == want
    assert got != evaluate(plain, DETUMBLE, EPISODES, SEED, only=["model", "pd"])


def test_env_kwargs_flag_json_and_pairs(capsys):
    """Item 7. --env-kwargs takes a JSON object or KEY=VALUE pairs (dotted keys nest) and
    evaluates on exactly that env."""
    base = ["none", "--env", DETUMBLE, "--episodes", "6", "--only", "pd", "--json"]
    assert ev.main([*base, "--env-kwargs", '{"randomization": {"inertia": 0.2}, "dt": 0.02}']) == 0
    as_json = json.loads(capsys.readouterr().out)
    assert ev.main([*base, "--env-kwargs", "randomization.inertia=0.2", "dt=0.02"]) == 0
    as_pairs = json.loads(capsys.readouterr().out)
    assert as_json == as_pairs
    assert as_json["env_kwargs"] == {"randomization": {"inertia": 0.2}, "dt": 0.02}
    api = evaluate(
        None, DETUMBLE, 6, 12345, ["pd"], {"randomization": {"inertia": 0.2}, "dt": 0.02}
    )
    assert {k: v for k, v in as_json.items() if k != "env_kwargs"} == api["pd"]


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (["--env-kwargs", "{bad json"], ["--env-kwargs", "not valid JSON"]),
        (["--env-kwargs", "dt"], ["--env-kwargs", "KEY=VALUE"]),
        (["--env-kwargs", "integrator=rk5"], ["integrator", "rk5", "rk4"]),
        (["--env-kwargs", "randomization.inertai=0.2"], ["randomization.inertai", "inertia"]),
        (["--env-kwargs", "wind=3"], ["wind", "unknown keyword"]),
        (["--seed", "-1"], ["--seed", ">= 0"]),
        (["--episodes", "0"], ["--episodes", ">= 1"]),
        (["--only", "pd,pid"], ["--only", "pid"]),
    ],
)
def test_bad_flags_are_one_line(capsys, flags, words):
    """Items 7 and 9: each mistake is one line naming the flag and what to do."""
    assert ev.main(["none", "--env", DETUMBLE, "--episodes", "2", *flags]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert_one_line_error(captured.err, ERR, *words)


def test_kwargs_that_change_the_observation_are_one_line():
    """Item 7. Through the Python API, env_kwargs that give another observation shape than
    the model's are an EvaluationError naming both shapes, not a broadcast error."""
    model = PRETRAINED / "ppo_detumble.zip"
    with pytest.raises(EvaluationError) as exc:
        evaluate(model, DETUMBLE, 2, 0, only=["model"], env_kwargs={"rotation_repr": "sixd"})
    text = str(exc.value)
    assert "\n" not in text and "rotation_repr" in text and "(10,)" in text


def test_video_goes_to_exactly_the_given_path(tmp_path, capsys):
    """Item 7. --video out.mp4 writes out.mp4 (and nothing else), after the results."""
    out = tmp_path / "videos" / "out.mp4"
    argv = ["none", "--env", DETUMBLE, "--episodes", "2", "--only", "pd", "--video", str(out)]
    assert ev.main(argv) == 0
    assert sorted(p.name for p in out.parent.iterdir()) == ["out.mp4"]
    assert out.read_bytes()[4:8] == b"ftyp"  # an MP4 file
    assert "| pd |" in capsys.readouterr().out
    assert ev.main(argv) == 2  # it exists now: refused without --force
    assert_one_line_error(capsys.readouterr().err, ERR, "--video", "--force")


def test_time_to_success_counts_only_successful_episodes():
    """Item 7. SpinStabilize's zero policy never succeeds (it touches the success condition
    and loses it): no time to success, not 1.11 s; and for every policy the time is None
    exactly when no episode succeeds."""
    res = evaluate(None, "RigidEnv/SpinStabilize-v0", 8, 500, only=["zero", "pd", "random"])
    assert res["zero"]["success_rate"] == 0.0 and res["zero"]["mean_time_to_success"] is None
    for r in res.values():
        assert (r["mean_time_to_success"] is None) == (r["success_rate"] == 0.0), r
    assert res["pd"]["mean_time_to_success"] > 0.0


def _stats_case(folder: Path, case: str) -> Path:
    """A model whose statistics file is broken in the way ``case`` names."""
    model = _copy_model(folder, "m.zip", "m_vecnormalize.pkl", _sidecar("m_vecnormalize.pkl"))
    stats = folder / "m_vecnormalize.pkl"
    if case == "truncated":
        stats.write_bytes(stats.read_bytes()[:100])
    elif case == "foreign":
        stats.write_bytes(pickle.dumps({"mean": [0.0] * 10}))
    elif case == "other_task":
        shutil.copy(PRETRAINED / "ppo_reorient_vecnormalize.pkl", stats)
    return model


@pytest.mark.parametrize(
    ("case", "words"),
    [
        ("truncated", ["m_vecnormalize.pkl", "not readable", "restore"]),
        ("foreign", ["m_vecnormalize.pkl", "dict", "not VecNormalize"]),
        ("other_task", ["m_vecnormalize.pkl", "shape", "(10,)"]),
    ],
)
def test_broken_statistics_are_one_line(tmp_path, capsys, case, words):
    """Item 9. Corrupted, foreign or mismatched statistics: one line, no evaluation."""
    model = _stats_case(tmp_path, case)
    assert ev.main([str(model), "--env", DETUMBLE, "--episodes", "2", "--only", "model"]) == 2
    assert_one_line_error(capsys.readouterr().err, ERR, *words)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("{not json", ["m.json", "not a valid JSON sidecar"]),
        ('{"env_id": "RigidEnv/Detumble-v0", "env_kwargs": [1]}', ["m.json", "env_kwargs"]),
        ('{"env_id": "RigidEnv/Detumble-v0", "algo": "dqn"}', ["m.json", "algo"]),
    ],
)
def test_invalid_sidecar_is_one_line(tmp_path, capsys, text, words):
    """Item 9. A sidecar that is not JSON, or has fields of the wrong kind: one line."""
    model = _copy_model(tmp_path, "m.zip", "m_vecnormalize.pkl", None)
    model.with_suffix(".json").write_text(text)
    assert ev.main([str(model), "--env", DETUMBLE, "--episodes", "2", "--only", "model"]) == 2
    assert_one_line_error(capsys.readouterr().err, ERR, *words)


def test_unwritable_video_path_is_refused_before_the_evaluation(tmp_path, capsys):
    """Item 9. --video into a folder that cannot be written: one line before any work."""
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    bad = blocker / "out.gif"  # a path below a file can never be created
    argv = ["none", "--env", DETUMBLE, "--episodes", "2", "--only", "pd", "--video", str(bad)]
    assert ev.main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # nothing evaluated
    assert_one_line_error(captured.err, ERR, "--video", str(bad), "choose a folder")


def test_video_failure_keeps_the_results(tmp_path, capsys, monkeypatch):
    """Item 9. If writing the video fails after the evaluation (a full disk), the results are
    already printed and the error is one line."""

    def fail(*args: object, **kwargs: object) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(ev, "record_video", fail)
    out = tmp_path / "out.gif"
    argv = ["none", "--env", DETUMBLE, "--episodes", "2", "--only", "pd", "--video", str(out)]
    assert ev.main(argv) == 1
    captured = capsys.readouterr()
    assert "| pd |" in captured.out
    assert_one_line_error(captured.err, ERR, "--video", "No space left")


@pytest.mark.slow
def test_cli_error_is_one_line_in_a_fresh_process(tmp_path):
    """Item 9 end to end: exit status 2, one stderr line, no traceback."""
    model = _stats_case(tmp_path, "truncated")
    proc = run_module("agents.evaluate", str(model), "--env", DETUMBLE, "--episodes", "2")
    assert proc.returncode == 2 and proc.stdout == ""
    assert_one_line_error(proc.stderr, ERR, "m_vecnormalize.pkl")


@pytest.mark.parametrize(
    ("flags", "words"),
    [(["--episodes", "x"], ["--episodes", "integer"]), (["--bogus"], ["--bogus", "--help"])],
)
def test_flag_syntax_errors_are_one_line(capsys, flags, words):
    """A flag argparse rejects is one line too, not its usage block."""
    with pytest.raises(SystemExit) as exc:
        ev.main(["none", "--env", DETUMBLE, *flags])
    assert exc.value.code == 2
    assert_one_line_error(capsys.readouterr().err, ERR, *words)


def test_episodes_in_exponent_notation(capsys):
    assert (
        ev.main(["none", "--env", DETUMBLE, "--episodes", "4e0", "--only", "zero", "--json"]) == 0
    )
    assert json.loads(capsys.readouterr().out)["episodes"] == 4
