"""Policies named with their options, as the command line gives them (``NAME:KEY=VALUE,...``,
``policies.registry.split_spec``): parsed values, the label, and clear errors."""

from __future__ import annotations

import pytest

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.episodes.rollout import run_episode
from policies.registry import split_spec


@pytest.mark.parametrize(
    ("spec", "name", "options"),
    [
        ("prioritized", "prioritized", {}),
        ("lookahead:candidates=20", "lookahead", {"candidates": 20}),
        ("prioritized:rank=nearest,max_searches=4", "prioritized",
         {"rank": "nearest", "max_searches": 4}),
        ("greedy:patience=2.5", "greedy", {"patience": 2.5}),
        ("runs/x-s0:break_waits=false", "runs/x-s0", {"break_waits": False}),
        ("lookahead: candidates = 3 , guide = runs/a-s1", "lookahead",
         {"candidates": 3, "guide": "runs/a-s1"}),
    ],
)  # fmt: skip
def test_a_spec_gives_its_name_and_typed_options(spec, name, options):
    assert split_spec(spec) == (name, options)


def test_an_existing_path_with_a_colon_is_a_name(tmp_path):
    path = tmp_path / "run:1"
    path.mkdir()
    assert split_spec(str(path)) == (str(path), {})


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("lookahead:candidates", "'candidates' is not KEY=VALUE"),
        ("lookahead:", "'' is not KEY=VALUE"),
        ("lookahead:=3", "'=3' is not KEY=VALUE"),
        ("lookahead:candidates=", "is not KEY=VALUE"),
        ("lookahead:2x=1", "'2x=1' is not KEY=VALUE"),
        ("lookahead:candidates=2,candidates=3", "'candidates' is given twice"),
    ],
)
def test_a_malformed_spec_is_refused_naming_the_option(spec, message):
    with pytest.raises(policies.PolicyError, match=message):
        policies.factory(spec)


def test_spec_options_reach_the_policy_and_label_it():
    env = MultiCraneEnv("e2s2", n_cranes=2, decisions="task")
    made = policies.factory("lookahead:candidates=0")
    assert made.label == "lookahead:candidates=0" and made.options == {"candidates": 0}
    assert made(env, 0).candidates == 0
    by_spec = run_episode(env, made(env, 0), seed=0, record=True)
    by_option = run_episode(env, policies.make("lookahead", env, 0, candidates=0), seed=0,
                            record=True)  # fmt: skip
    assert by_spec["actions"] == by_option["actions"]
    assert policies.factory("prioritized").label == "prioritized"


def test_an_option_the_policy_does_not_take_is_named():
    env = MultiCraneEnv("e2s2", n_cranes=2, decisions="task")
    with pytest.raises(policies.PolicyError, match="'lookahead:cands=2'.*'cands'"):
        policies.factory("lookahead:cands=2")(env, 0)


def test_a_guide_must_be_a_trained_model():
    with pytest.raises(policies.PolicyError, match="guide='prioritized' is not a trained model"):
        policies.factory("lookahead:guide=prioritized")
    with pytest.raises(policies.PolicyError, match="no such run directory"):
        policies.factory("lookahead:guide=runs/no-such-run")


def test_plan_prints_a_policy_with_options_under_its_whole_label(capsys):
    from multicrane.cli import main

    spec = "prioritized:rank=nearest,max_searches=2"  # longer than the 24 columns of a name
    assert main(["plan", "e2s2", "--cranes", "2", "--decisions", "task", "--policy", spec,
                 "greedy"]) == 0  # fmt: skip
    rows = [r for r in capsys.readouterr().out.splitlines() if r.startswith(spec)]
    assert len(rows) == 1 and "100%" in rows[0]


@pytest.mark.parametrize(
    ("spec", "name"),
    [("lookahead", "lookahead"), ("lookahead:candidates=20", "lookahead"),
     ("prioritized:rank", "prioritized"), ("runs/x-s0", "runs/x-s0")],
)  # fmt: skip
def test_the_layers_below_read_the_name_alone(spec, name):
    from multicrane.episodes.policy_spec import spec_name

    assert spec_name(spec) == name  # a malformed option still names its policy
