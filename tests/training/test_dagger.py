"""Rounds after imitation (``multicrane.training.dagger``, ``expert_iteration``): in DAgger
the learner plays and the teacher labels its states, every labelled row is kept; expert
iteration searches over the policy; a run with rounds is deterministic for its seed and a
rerun reads its rounds' rows instead of asking the teacher again."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th
from conftest import one_torch_thread  # noqa: F401 (fixture)

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.tasks.task_list import exclusive_masks, task_list
from multicrane.training import ConfigError, TrainConfig, train
from multicrane.training.dagger import PaddedLearner, merge, rounds_file
from multicrane.training.expert_iteration import PolicyPlanner, guided_teacher
from multicrane.training.imitation import Demonstrations, demonstrate
from multicrane.training.model_policy import SetModelPolicy, load_run
from multicrane.training.set_obs import SetLimits
from multicrane.training.set_training import make_set_model, set_hyperparameters
from multicrane.training.set_vec_env import SetVecEnv

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _venv(name="e3s3", copies=2):
    make = lambda i: MultiCraneEnv(name, n_cranes=2, decisions="task", reward="makespan")  # noqa: E731
    return SetVecEnv(make, copies, SetLimits.of(make(0).observation_layout), 0.0, 1.0)


class _Spy:
    """A teacher factory that records every joint action its planners return."""

    def __init__(self, name: str):
        self.make, self.said = policies.factory(name), []

    def __call__(self, env, seed):
        planner = self.make(env, seed)

        def act(observations):
            joint = planner(observations)
            self.said.append([joint[a] for a in env.possible_agents])
            return joint

        return act


def _as_learner(name: str):
    """``make_learner`` playing planner ``name`` with exclusive claims (as ``demonstrate``
    plays a teacher)."""

    def make(env, copy):
        planner = policies.factory(name)(env, None)

        def act(rows, masks):
            joint = planner({a: {"action_mask": m} for a, m in env.action_masks().items()})
            choices = [joint[a] for a in env.possible_agents]
            return exclusive_masks(masks, choices, task_list(env))[1]

        return act

    return make


def test_the_teacher_labels_the_states_the_learner_plays():
    # The learner (the greedy planner) plays; the prioritized planner only labels. The states
    # and episodes are the greedy planner's own, the labels the prioritized planner's.
    alone = _venv()
    alone.seed(4)
    greedy = demonstrate(alone, policies.factory("greedy"), 3, gamma=1.0)
    venv = _venv()
    venv.seed(4)
    spy = _Spy("prioritized")
    labelled = demonstrate(venv, spy, 3, gamma=1.0, make_learner=_as_learner("greedy"))
    assert np.array_equal(labelled.observations, greedy.observations)
    assert labelled.makespans == greedy.makespans
    assert np.array_equal(labelled.returns, greedy.returns)
    # Every copy's pair of rows holds a joint action the teacher gave (rows: round after
    # round, copy after copy, two cranes each), and the labels are not the learner's.
    said = {tuple(x) for x in spy.said}
    pairs = labelled.actions.reshape(-1, 2)
    assert all(tuple(pair) in said for pair in pairs.tolist())
    assert not np.array_equal(labelled.actions, greedy.actions)
    assert labelled.masks[np.arange(len(labelled)), labelled.actions].all()


def test_the_aggregate_keeps_every_labelled_row():
    venv = _venv()
    venv.seed(0)
    a = demonstrate(venv, policies.factory("prioritized"), 2, gamma=0.99)
    venv.seed(1)
    b = demonstrate(venv, policies.factory("greedy"), 3, gamma=0.99)
    both = merge(a, b)
    assert len(both) == len(a) + len(b) and both.makespans == a.makespans + b.makespans
    for name in ("observations", "masks", "actions", "returns"):
        whole = getattr(both, name)
        assert np.array_equal(whole[: len(a)], getattr(a, name))
        assert np.array_equal(whole[len(a) :], getattr(b, name))


def _rows_of(observations: list[float], actions: list[int], values: bool) -> Demonstrations:
    n = len(actions)
    return Demonstrations(
        observations=np.array(observations, dtype=np.float32)[:, None],
        masks=np.ones((n, 4), dtype=bool), actions=np.array(actions),
        returns=np.arange(n, dtype=np.float32), makespans=[n],
        values=np.full((n, 4), float(n), dtype=np.float32) if values else None,
    )  # fmt: skip


@pytest.mark.parametrize("values", [False, True])
def test_a_later_round_s_label_replaces_an_earlier_one_at_the_same_state(values):
    # Observations 1 and 2 were labelled by the earlier round (actions 1, 2) and again by the
    # later one (actions 3, 3): only the later labels stay; state 0 keeps its one label.
    early = _rows_of([0.0, 1.0, 2.0, 1.0], [0, 1, 2, 1], values=values)
    late = _rows_of([2.0, 1.0, 5.0], [3, 3, 3], values=False)
    both = merge(early, late, newest=True)
    assert both.observations[:, 0].tolist() == [0.0, 2.0, 1.0, 5.0]
    assert both.actions.tolist() == [0, 3, 3, 3]
    assert both.returns.tolist() == [0.0, 0.0, 1.0, 2.0]
    assert both.makespans == [4, 3]
    if values:  # the earlier rows' values ride along; the later file had none: NaN
        assert both.values[0].tolist() == [4.0] * 4 and np.isnan(both.values[1:]).all()
    else:
        assert both.values is None
    # Without ``newest`` every row stays (DAgger's aggregate).
    assert len(merge(early, late)) == 7


def test_the_padded_learner_is_the_deployed_policy():
    venv = _venv("e3s2")
    model = make_set_model(venv, 0, set_hyperparameters({}), None)
    env = MultiCraneEnv("e3s2", n_cranes=2, decisions="task", reward="makespan")
    deployed = SetModelPolicy(model, env)
    learner = PaddedLearner(model.policy, env)
    observations, _ = env.reset(seed=3)
    for _ in range(40):
        rows = np.stack([deployed.padder.pad(o["observation"]) for o in observations.values()])
        masks = np.stack([deployed.padder.pad_mask(o["action_mask"])
                          for o in observations.values()])  # fmt: skip
        joint = deployed(observations)
        assert learner(rows, masks).tolist() == [joint[a] for a in env.possible_agents]
        observations, _, terms, truncs, _ = env.step(joint)
        if any(terms.values()) or any(truncs.values()):
            break


def test_dagger_needs_imitation_and_the_set_policy():
    with pytest.raises(ConfigError, match="dagger=2: needs imitate"):
        TrainConfig("e3s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                    policy="set", dagger=2)  # fmt: skip
    with pytest.raises(ConfigError, match="dagger=1: needs policy='set'"):
        TrainConfig("e3s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                    imitate="prioritized", dagger=1)  # fmt: skip


def _rounds_cfg(demos: str, **rounds) -> TrainConfig:
    return TrainConfig("e3s3", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                       policy="set", imitate="prioritized", imitate_episodes=4,
                       imitate_epochs=5, round_episodes=3, reward="makespan",
                       shaping=0.0, n_envs=2, total_steps=32, eval_episodes=2,
                       checkpoint_every=0, imitate_demos=demos, **rounds,
                       hyperparams={"n_steps": 16, "batch_size": 64, "n_epochs": 1,
                                    "learning_rate": 0.0})  # fmt: skip


def _timeless(rounds: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "seconds"} for r in rounds]


def _same_weights(a_dir, b_dir) -> bool:
    a, _ = load_run(a_dir)
    b, _ = load_run(b_dir)
    sa, sb = a.policy.state_dict(), b.policy.state_dict()
    return all(th.equal(sa[k], sb[k]) for k in sa)


def test_a_dagger_run_end_to_end_and_its_rerun_reads_the_labels(tmp_path):
    demos = str(tmp_path / "demos.npz")
    cfg = _rounds_cfg(demos, dagger=2)
    teacher = policies.factory("prioritized")
    ref = train(cfg, tmp_path / "ref", teacher=teacher, log=lambda *a: None)
    summary = ref["imitation"]["rounds"]
    rounds = summary["rounds"]
    assert [r["round"] for r in rounds] == ["imitation", "dagger-1", "dagger-2"]
    assert ref["imitation"]["rows"] < rounds[1]["rows"] < rounds[2]["rows"]  # it grows
    assert {r.get("played") for r in rounds[1:]} == {"learner"}
    for r in (1, 2):
        assert rounds_file(demos, "dagger", cfg.seed, r).exists()
    best = max(rounds, key=lambda r: (r["success_rate"], r["return_mean"]))
    assert summary["kept_round"] == best["round"]
    # A rerun reads the labelled rows of every round and ends with the same weights.
    spy = _Spy("prioritized")
    again = train(cfg, tmp_path / "again", teacher=spy, log=lambda *a: None)
    assert spy.said == []  # the teacher was not asked again
    assert _timeless(again["imitation"]["rounds"]["rounds"]) == _timeless(rounds)
    assert _same_weights(tmp_path / "ref", tmp_path / "again")


def test_the_policy_planner_is_the_greedy_deployed_policy_and_skips_empty_rounds():
    venv = _venv("e3s2")
    model = make_set_model(venv, 0, set_hyperparameters({}), None)
    env = MultiCraneEnv("e3s2", n_cranes=2, decisions="task", reward="makespan")
    deployed, planner = SetModelPolicy(model, env), PolicyPlanner(model.policy, env)
    observations, _ = env.reset(seed=1)
    skipped = 0
    for _ in range(60):
        joint = deployed(observations)
        assert planner(observations) == joint
        masks_only = {a: {"action_mask": o["action_mask"]} for a, o in observations.items()}
        assert planner(masks_only) == joint  # reads the observations from the environment
        if not any(o["action_mask"][1:].any() for o in observations.values()):
            skipped += 1
            assert set(joint.values()) == {0}
        observations, _, terms, truncs, _ = env.step(joint)
        if any(terms.values()) or any(truncs.values()):
            break
    assert any(terms.values()) and skipped > 0


def test_expert_iteration_needs_a_search_teacher():
    with pytest.raises(ConfigError, match="expert_iteration: the teacher is not a search"):
        guided_teacher(policies.factory("prioritized"), None)


def test_an_expert_iteration_run_guides_the_search_with_the_policy(tmp_path):
    from policies.lookahead import LookaheadTeacher

    demos = str(tmp_path / "demos.npz")
    cfg = _rounds_cfg(demos, dagger=1, expert_iteration=1)
    teacher = LookaheadTeacher(candidates=1)
    ref = train(cfg, tmp_path / "ref", teacher=teacher, log=lambda *a: None)
    rounds = ref["imitation"]["rounds"]["rounds"]
    assert [r["round"] for r in rounds] == ["imitation", "dagger-1", "expit-1"]
    expit = rounds[2]
    assert expit["played"] == "teacher" and expit["played_makespan_mean"] is not None
    assert rounds_file(demos, "expit", cfg.seed, 1).exists()
    # Its refit reads only the expert's own rows: fewer than DAgger's aggregate.
    assert expit["rows"] < rounds[1]["rows"]
    again = train(cfg, tmp_path / "again", teacher=teacher, log=lambda *a: None)
    assert _timeless(again["imitation"]["rounds"]["rounds"]) == _timeless(rounds)
    assert _same_weights(tmp_path / "ref", tmp_path / "again")


def test_the_train_command_passes_the_rounds_and_a_search_teacher():
    import argparse

    from multicrane.cli import train as train_cli
    from policies.lookahead import LookaheadTeacher

    parser = argparse.ArgumentParser()
    train_cli.register(parser.add_subparsers())
    argv = ["train", "--scenario", "hall-4c", "--cranes", "4", "--decisions", "task",
            "--policy", "set", "--imitate", "lookahead", "--dagger", "2",
            "--expert-iteration", "3", "--round-episodes", "16"]  # fmt: skip
    cfg = train_cli.build_config(parser.parse_args(argv))
    assert (cfg.dagger, cfg.expert_iteration, cfg.round_episodes) == (2, 3, 16)
    assert cfg.imitate_stop is None
    stop = train_cli.build_config(parser.parse_args([*argv, "--imitate-stop", "1"]))
    assert stop.imitate_stop == 1.0
    assert isinstance(train_cli.teacher_of(cfg), LookaheadTeacher)
    cfg = train_cli.build_config(parser.parse_args(argv[:-4]))
    assert not isinstance(train_cli.teacher_of(cfg), LookaheadTeacher)  # the registry's
    given = [x if x != "lookahead" else "lookahead:candidates=8" for x in argv]
    teacher = train_cli.teacher_of(train_cli.build_config(parser.parse_args(given)))
    assert isinstance(teacher, LookaheadTeacher) and teacher.options == {"candidates": 8}
