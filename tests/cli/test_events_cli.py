"""Site events from the command line and in training: ``--events`` of ``plan``, ``evaluate``
and ``train`` reaches the environment (its spec, the ``site_event_counts`` info), is stored in
a run's configuration and reused by ``evaluate``/``plan --policy RUN_DIR``; bad values are
refused with a clear message; the set policy carries the events' columns (``delivered``,
``available``) and plays sites with and without events.

Budgets are tiny: these tests check the wiring, not learning.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import play_legal

import multicrane
from multicrane.cli import build_parser, main
from multicrane.sim.events import preset
from multicrane.training.config import ConfigError, TrainConfig


@pytest.fixture
def built(monkeypatch):
    """Every multi-agent environment the commands build, in order."""
    envs = []
    original = multicrane.parallel_env

    def spy(*args, **kwargs):
        env = original(*args, **kwargs)
        envs.append(env)
        return env

    monkeypatch.setattr(multicrane, "parallel_env", spy)
    return envs


def _has_level(env, level: str | None) -> bool:
    """Whether ``env`` runs the events of ``level`` (None: the static site)."""
    if level is None:
        return env.sim.events is None
    if env.sim.events != preset(level, env.scenario):
        return False
    _, infos = env.reset(seed=0)
    return all("site_event_counts" in info for info in infos.values())


# -- the option reaches the environment ----------------------------------------------------------

CASES = [
    (["plan", "e2s2", "--policy", "greedy", "--events", "high"], "high"),
    (["plan", "e2s2", "--policy", "greedy", "--events", "none"], "none"),
    (["plan", "e2s2", "--policy", "greedy"], None),
    (["evaluate", "--scenario", "e2s2", "--policy", "greedy", "--episodes", "1", "--seed", "0",
      "--events", "low"], "low"),  # fmt: skip
    (["evaluate", "--scenario", "e2s2", "--decisions", "task", "--policy", "random",
      "--episodes", "1", "--seed", "0", "--events", "high"], "high"),  # fmt: skip
    (["evaluate", "--scenario", "e2s2", "--policy", "greedy", "--episodes", "1", "--seed", "0"],
     None),  # fmt: skip
]


@pytest.mark.parametrize("argv, level", CASES, ids=[" ".join(c[0][:2] + c[0][-2:]) for c in CASES])
def test_events_option_reaches_the_environment(argv, level, built, capsys):
    assert main(argv) == 0, capsys.readouterr().err
    assert built and all(_has_level(env, level) for env in built)


def test_task_level_observation_gains_the_event_columns(built, capsys):
    argv = ["evaluate", "--scenario", "e2s2", "--decisions", "task", "--policy", "random",
            "--episodes", "1", "--seed", "0", "--events", "low"]  # fmt: skip
    assert main(argv) == 0
    layout = built[0].observation_layout
    assert layout.events is not None  # delivered, available columns and the closed block
    static = multicrane.parallel_env("e2s2", decisions="task").observation_layout
    assert layout.size > static.size


@pytest.mark.parametrize(
    "argv, message",
    [
        (["plan", "e2s2", "--events", "medium"], "invalid choice: 'medium'"),
        (["evaluate", "--scenario", "e2s2", "--policy", "greedy", "--events", "x"],
         "invalid choice: 'x'"),  # fmt: skip
        (["train", "--scenario", "e2s2", "--events", "hi"], "invalid choice: 'hi'"),
    ],
)
def test_bad_levels_are_refused_by_name(argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["plan", "E2S2", "--paper", "--policy", "greedy", "--events", "low"],
         "--events low is a multi-agent option"),  # fmt: skip
        (["evaluate", "--paper", "E2S2", "--policy", "greedy", "--episodes", "1",
          "--events", "high"], "--events high is a multi-agent option"),  # fmt: skip
    ],
)
def test_events_in_paper_mode_are_refused(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"events": "medium"}, "events='medium': one of none, low, high"),
        ({"events": "low", "paper": True, "scenario": "E2S2"}, "events='low': a multi-agent"),
        ({"events": "low", "policy": "set", "decisions": "task", "algo": "maskable_ppo",
          "scenario": "set:train", "curriculum": "grow"}, "not available with a curriculum"),
    ],
)  # fmt: skip
def test_config_checks_the_events(changes, message):
    kw = {"scenario": "e2s2", "paper": False, **changes}
    with pytest.raises(ConfigError, match=message):
        TrainConfig(**kw)


def test_train_options_store_the_level():
    from multicrane.cli.train import build_config

    parser = build_parser()
    for decisions in ("motion", "task"):
        args = parser.parse_args(["train", "--scenario", "e2s2", "--decisions", decisions,
                                  "--events", "low"])  # fmt: skip
        cfg = build_config(args)
        assert (cfg.events, cfg.decisions) == ("low", decisions)
        assert TrainConfig.from_dict(cfg.to_dict()) == cfg
    cfg = build_config(parser.parse_args(["train", "--scenario", "e2s2"]))
    assert cfg.events is None and "events" in cfg.to_dict()
    old = cfg.to_dict()
    del old["events"]  # a config.json written before the option loads as before
    assert TrainConfig.from_dict(old).events is None


# -- a run trained with events: stored, resumed, reused ------------------------------------------



@pytest.fixture(scope="module")
def events_run(tmp_path_factory):
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("sb3_contrib")
    import torch as th

    th.set_num_threads(1)
    out = tmp_path_factory.mktemp("runs") / "set-low"
    argv = ["train", "--scenario", "e2s2", "--cranes", "2", "--decisions", "task", "--policy",
            "set", "--events", "low", "--steps", "64", "--envs", "2", "--eval-episodes", "1",
            "--checkpoint-every", "0", "--set", "n_steps=16", "--set", "batch_size=32",
            "--no-progress", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    return out, argv


def test_a_run_trained_with_events_stores_and_reuses_the_level(events_run, built, capsys):
    out, argv = events_run
    assert json.loads((out / "config.json").read_text())["events"] == "low"
    assert main(argv) == 0  # the same command again: the finished run is reported
    assert "low" in json.dumps(json.loads((out / "result.json").read_text())["config"])
    changed = [a if a != "low" else "high" for a in argv]
    assert main(changed) == 2
    assert "events: 'low' != 'high'" in capsys.readouterr().err
    built.clear()
    assert main(["evaluate", "--scenario", "e2s2", "--cranes", "2", "--decisions", "task",
                 "--policy", str(out), "--episodes", "1", "--seed", "0"]) == 0  # fmt: skip
    assert built and all(_has_level(env, "low") for env in built)  # the run's level


# -- the set policy with events ------------------------------------------------------------------


def test_set_policy_with_events_plays_legally_and_on_a_static_site(events_run):
    from multicrane.training.model_policy import SetModelPolicy, load_run

    model, cfg = load_run(events_run[0])
    limits = model.policy.features_extractor.limits
    assert limits.events and cfg.events == "low"
    for events in ("high", None):  # None: e2s2 has no [events] table, a static site
        env = multicrane.parallel_env("e2s2", n_cranes=2, decisions="task", events=events)
        policy = SetModelPolicy(model, env, deterministic=False)
        for seed in range(2):
            play_legal(env, policy, seed=seed, steps=40, label=f"events={events}")


def test_set_padding_carries_delivered_and_available():
    pytest.importorskip("torch")
    from multicrane.training.set_obs import Padder, SetLimits

    env = multicrane.parallel_env("hall-4c", n_cranes=4, decisions="task", events="high")
    obs, _ = env.reset(seed=0)
    layout = env.observation_layout
    flat = obs["crane_0"]["observation"]
    tables = layout.split(flat)
    big = SetLimits(layout.n_components + 2, 5, layout.n_tasks + 3, events=True)
    padded = Padder(layout, big).pad(flat)
    got = {}
    for name, (a, b, shape) in big.slices().items():
        got[name] = padded[a:b].reshape(shape)
    C, N = layout.n_components, layout.n_cranes
    delivered = tables["components"][:, -1]
    assert 0 < delivered.sum() < C  # "high" makes some components late at reset
    assert np.array_equal(got["components"][:C, -1], delivered)
    assert np.array_equal(got["components"][:C, : 21 + N], tables["components"][:, :-1])
    assert np.array_equal(got["cranes"][:N], tables["cranes"])
    assert not got["components"][C:].any() and not got["cranes"][N:].any()
    # A static site under limits with events: every component delivered, every crane up.
    static = multicrane.parallel_env("hall-4c", n_cranes=4, decisions="task")
    o, _ = static.reset(seed=0)
    p = Padder(static.observation_layout, big).pad(o["crane_0"]["observation"])
    comp = p[slice(*big.slices()["components"][:2])].reshape(big.slices()["components"][2])
    assert np.all(comp[:C, -1] == 1) and not comp[C:, -1].any()
    # A site with events under limits without them: refused, naming the option.
    with pytest.raises(ValueError, match="train it with events"):
        Padder(layout, SetLimits(C, N, layout.n_tasks))


@pytest.mark.parametrize("policy, decisions", [("mlp", "motion"), ("mlp", "task"),
                                               ("set", "task")])  # fmt: skip
def test_training_environments_have_the_runs_events(policy, decisions):
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("sb3_contrib")
    from multicrane.training.algorithms import algorithm
    from multicrane.training.trainer import make_vec_env

    cfg = TrainConfig(scenario="e2s2", paper=False, n_cranes=2, algo="maskable_ppo",
                      decisions=decisions, policy=policy, events="high", n_envs=1)  # fmt: skip
    venv = make_vec_env(cfg, algorithm(cfg.algo, False), {})
    assert all(_has_level(env, "high") for env in venv.envs)
    if policy == "set":
        assert venv.limits.events


def test_rllib_backend_passes_the_level_to_its_environments(monkeypatch, capsys):
    rllib = pytest.importorskip("multicrane.integrations.rllib", exc_type=ImportError)
    from multicrane.integrations import rllib_train

    seen = {}

    def fake_train(scenario, n_cranes, out, **kwargs):
        seen.update(kwargs["env_options"])
        raise ValueError("stopped before Ray")

    monkeypatch.setattr(rllib_train, "train_rllib", fake_train)
    argv = ["train", "--backend", "rllib", "--scenario", "e2s2", "--decisions", "task",
            "--events", "low"]  # fmt: skip
    assert main(argv) == 2 and "stopped before Ray" in capsys.readouterr().err
    assert seen == {"auto": False, "decisions": "task", "events": "low"}
    env = rllib.CraneMultiAgentEnv({"scenario": "e2s2", "n_cranes": 2, **seen})
    assert _has_level(env.env, "low")


def test_plan_with_a_motion_run_plays_its_level_unless_told(tmp_path, built, capsys):
    pytest.importorskip("stable_baselines3")
    pytest.importorskip("sb3_contrib")
    out = tmp_path / "mlp-high"
    assert main(["train", "--scenario", "e2s2", "--cranes", "2", "--events", "high", "--steps",
                 "64", "--envs", "1", "--eval-episodes", "1", "--checkpoint-every", "0",
                 "--set", "n_steps=32", "--set", "batch_size=32", "--no-progress",
                 "--out", str(out)]) == 0  # fmt: skip
    for extra, level in (([], "high"), (["--events", "none"], "none")):
        built.clear()
        assert main(["plan", "e2s2", "--cranes", "2", "--policy", str(out), *extra]) == 0
        assert built and all(_has_level(env, level) for env in built)


def test_uncertainty_benchmark_plays_a_task_level_run(events_run, capsys):
    out = events_run[0]
    assert main(["uncertainty", "--scenarios", "e2s2:2", "--levels", "none", "high",
                 "--policies", str(out), "replanning", "--seeds", "1",
                 "--bound-time", "0"]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert f"maskable_ppo ({out.name})" in text and "| e2s2 | 2 | high |" in text
