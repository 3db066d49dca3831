"""Scene, training and sweep files mean what their author wrote (issue 28, sections 3 and 6).

A key given twice is refused by structure in every YAML style; a file with several problems
names the likeliest mistake first (an unknown key, with the allowed key nearest to it) and counts
every other problem; a NUL byte and a non-string key are named where they are.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from reliability_helpers import ROOT, TINY

from agents.config import ConfigError, load_config
from agents.sweep_config import load_sweep
from rigid_env.config_files import ConfigFileError, read_yaml
from rigid_env.scene import SceneError, load_scene

DETUMBLE = (ROOT / "configs" / "scenes" / "detumble.yaml").read_text()

#: (YAML text, the key named twice): every way YAML lets a mapping repeat a key.
DUPLICATES = [
    ("body: {mass: 1.0, mass: 2.0}\n", "'mass'"),  # the example: flow style, one line
    ("body:\n  mass: 1.0\n  mass: 2.0\n", "'mass'"),  # block style
    ("{dt: 0.1, dt: 0.2}\n", "'dt'"),  # a flow mapping at the top level
    ("dt: 0.1\n'dt': 0.2\n", "'dt'"),  # plain and quoted spellings of one key
    ('{"dt": 0.1, dt: 0.2}\n', "'dt'"),
    ("- {a: 1, a: 2}\n", "'a'"),  # inside a list
    ("outer:\n  inner: {x: [1, {y: 1, y: 2}]}\n", "'y'"),  # deep inside flow collections
    ("{1: a, 1.0: b}\n", "1.0"),  # equal keys of two types (Python would merge them)
    ("&k dt: 0.1\n*k : 0.2\n", "'dt'"),  # an alias of the first key
    ("~: 1\nnull: 2\n", "None"),  # two spellings of null
]


@pytest.mark.parametrize(("text", "key"), DUPLICATES)
def test_a_key_given_twice_is_refused_in_every_style(tmp_path, text, key):
    path = tmp_path / "dup.yaml"
    path.write_text(text)
    with pytest.raises(ConfigFileError) as info:
        read_yaml(path)
    message = str(info.value)
    assert f"key {key} given twice" in message and "keep one" in message, message
    assert "\n" not in message


def test_merge_keys_may_override_and_numbers_stay_numbers(tmp_path):
    """YAML's merge key brings keys that the mapping may then override (not a duplicate);
    `1e-4` and `1e5` stay numbers; the same key in two mappings is no duplicate."""
    path = tmp_path / "ok.yaml"
    path.write_text(
        "base: &b {mass: 1.0, dt: 2}\nbody:\n  <<: *b\n  mass: 2.0\n"
        "lr: 1e-4\nn: 1e5\nother: {mass: 1.0}\n"
    )
    data = read_yaml(path)
    assert data["body"] == {"mass": 2.0, "dt": 2}
    assert data["lr"] == 1e-4 and data["n"] == 1e5
    assert data["other"] == {"mass": 1.0}


def test_duplicates_are_refused_in_scenes_configs_and_sweeps(tmp_path):
    """The issue's example in each of the three file kinds, naming the file and the line."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(DETUMBLE.replace("  mass: 2.0\n", "  mass: 2.0\n  inertia: [1, 2, 3]\n"))
    load_scene(scene)  # the file is otherwise valid
    scene.write_text(
        DETUMBLE.replace(
            "body:\n  mass: 2.0\n  shape: {box: [0.4, 0.3, 0.2]}",
            "body: {mass: 1.0, mass: 2.0, shape: {box: [0.4, 0.3, 0.2]}}",
        )
    )
    with pytest.raises(SceneError, match=r"scene\.yaml: line 7: key 'mass' given twice"):
        load_scene(scene)

    config = tmp_path / "train.yaml"
    text = yaml.safe_dump(TINY, sort_keys=False)
    config.write_text(text.replace("n_epochs: 1", "n_epochs: 1\n  gamma: 0.9\n  gamma: 0.5"))
    with pytest.raises(ConfigError, match=r"train\.yaml: line \d+: key 'gamma' given twice"):
        load_config(config)
    config.write_text(text + "normalize: {obs: true, obs: false}\n")
    with pytest.raises(ConfigError, match=r"key 'obs' given twice"):
        load_config(config)

    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(f"name: s\nbase: {config}\nseeds: [0, 1]\nseeds: [2]\n")
    with pytest.raises(ConfigFileError, match=r"sweep\.yaml: line 4: key 'seeds' given twice"):
        load_sweep(sweep)


def test_a_nul_byte_names_its_line_and_column(tmp_path):
    path = tmp_path / "nul.yaml"
    path.write_text(DETUMBLE.replace("dt: 0.05", "dt: 0.0\x005"))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert message.startswith(f"{path}: line 4: ") and "U+0000 at column 8" in message, message


@pytest.mark.parametrize(
    ("extra", "where", "key", "kind"),
    [
        ("1: x\n", "top level", "1", "a number"),
        ("yes: 1\n", "top level", "true", "a boolean"),  # YAML 1.1 reads yes as true
        ("~: 1\n", "top level", "null", "nothing (null)"),
    ],
)
def test_a_key_that_is_not_a_name_is_named(tmp_path, extra, where, key, kind):
    path = tmp_path / "scene.yaml"
    path.write_text(DETUMBLE + extra)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert f"{where}: the key {key} is not a name (YAML read it as {kind})" in message, message
    assert "allowed keys: name, dt" in message


def test_a_non_string_key_inside_a_section_names_the_section(tmp_path):
    path = tmp_path / "scene.yaml"
    path.write_text(DETUMBLE.replace("  mass: 2.0\n", "  mass: 2.0\n  7: 3\n"))
    with pytest.raises(SceneError, match=r"body: the key 7 is not a name .* mass, shape"):
        load_scene(path)


def _scene_error(tmp_path: Path, text: str) -> str:
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    return str(info.value)


def test_an_unknown_key_is_named_first_with_the_nearest_allowed_key(tmp_path):
    """The issue's example: `bdy` for `body` names `bdy` (not "body: missing"), suggests body,
    and the missing body is the same mistake, not one more; a typo beside a bad value is named
    first and the bad value counted."""
    message = _scene_error(tmp_path, DETUMBLE.replace("body:", "bdy:"))
    assert ": bdy: unknown key; did you mean body? allowed keys: name, dt" in message, message
    assert "more)" not in message

    message = _scene_error(
        tmp_path, DETUMBLE.replace("dt: 0.05", "dt: -1").replace("substeps: 1", "substepz: 1")
    )
    assert ": substepz: unknown key; did you mean substeps?" in message, message
    assert message.endswith("(and 1 more)")

    text = DETUMBLE.replace("  mass: 2.0", "  mas: 2.0").replace("dt: 0.05", "dt: 0")
    message = _scene_error(tmp_path, text.replace("integrator: splitting", "integrator: 5"))
    assert ": body.mas: unknown key; did you mean mass?" in message, message
    assert message.endswith("(and 2 more)")  # dt and integrator


def _config_error(**changes: object) -> str:
    data = {**TINY, **changes}
    with pytest.raises(ConfigError) as info:
        load_config({k: v for k, v in data.items() if v is not None})
    return str(info.value)


def test_every_problem_is_counted_also_under_hyperparams_and_env_kwargs():
    """Problems in hyperparams (unknown to the algorithm, or out of range) and in env_kwargs
    count in "(and N more)" beside the top-level ones; the unknown key is named first."""
    hyper = {**TINY["hyperparams"], "learnin_rate": 0.1, "gamma": 5, "bogus": 1}
    message = _config_error(
        hyperparams=hyper, n_envs=0, env_kwargs={"integrator": "nope"}, total_timesteps=None
    )
    # Named: the unknown hyperparameter. Counted: bogus, gamma (> 1), n_envs, env_kwargs,
    # and the missing total_timesteps.
    assert "hyperparams.learnin_rate: not a PPO argument; did you mean learning_rate?" in message
    assert message.endswith("(and 5 more)"), message

    message = _config_error(n_envs=0, env_kwargs={"integrator": "nope"})
    assert "n_envs:" in message and message.endswith("(and 1 more)"), message

    message = _config_error(total_timestep=5, total_timesteps=None)
    assert "total_timestep: unknown key; did you mean total_timesteps?" in message
    assert "more)" not in message


def test_keys_the_algorithm_does_not_take_are_all_counted():
    """SAC takes neither n_steps' neighbour n_epochs nor PPO's policy option ortho_init."""
    message = _config_error(
        algo="sac",
        hyperparams={"n_epochs": 1, "clip_range": 0.2, "batch_size": 64},
        policy_kwargs={"net_arch": [16], "ortho_init": True},
    )
    # policy_kwargs comes before hyperparams in the file's field order.
    assert "policy_kwargs.ortho_init: not taken by SAC's policy" in message
    assert message.endswith("(and 2 more)"), message


@pytest.mark.parametrize("seed", [2**32, 10**30])
def test_a_seed_numpy_cannot_take_is_named_as_the_seed(seed):
    """Was "hyperparams: PPO refuses them (Seed must be between 0 and 2**32 - 1)", after the
    envs were built; now the seed field, its bound written in full, before any work."""
    message = _config_error(seed=seed)
    assert f"seed: must be less than or equal to 4294967295, got {seed};" in message, message
