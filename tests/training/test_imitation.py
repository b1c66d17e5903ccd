"""Imitation (``multicrane.training.imitation``): the teacher's rows, their returns, the fit,
and the training run that starts from it."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest
import torch as th
from conftest import one_torch_thread  # noqa: F401 (fixture)

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.training import ConfigError, TrainConfig, train
from multicrane.training.imitation import STOP_CHECK, _rows, agreement, clone, demonstrate
from multicrane.training.model_policy import load_run
from multicrane.training.set_obs import SetLimits
from multicrane.training.set_training import make_set_model, set_hyperparameters
from multicrane.training.set_vec_env import SetVecEnv
from multicrane.training.teaching import progress_log

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _venv(name="e3s2", n=2, copies=2, limits=None, reward="paper", shaping=0.0):
    make = lambda i: MultiCraneEnv(name, n_cranes=n, decisions="task", reward=reward)  # noqa: E731
    layout = make(0).observation_layout
    return SetVecEnv(make, copies, limits or SetLimits.of(layout), shaping, 0.99)


def test_returns_to_go_stop_at_each_episode_end_and_drop_unfinished_rows():
    # Two row streams over four rounds: stream 0 ends after round 1, stream 1 never ends.
    # Stream 0's rounds 2-3 belong to an episode that did not finish: they are dropped,
    # and so is all of stream 1; stream 1 is also not a real row in round 0.
    obs = [np.full((2, 3), t, dtype=np.float32) for t in range(4)]
    masks = [np.ones((2, 2), dtype=bool)] * 4
    actions = [np.array([t, 10 + t]) for t in range(4)]
    rewards = [np.array([1.0, 5.0]), np.array([2.0, 5.0]), np.array([4.0, 5.0]),
               np.array([8.0, 5.0])]  # fmt: skip
    dones = [np.array([False, False]), np.array([True, False]),
             np.array([False, False]), np.array([False, False])]  # fmt: skip
    real = [np.array([True, False])] + [np.array([True, True])] * 3
    log = list(zip(obs, masks, actions, rewards, dones, real, strict=True))
    demos = _rows(log, 0.5, [7])
    assert demos.actions.tolist() == [0, 1]
    assert demos.returns.tolist() == [1.0 + 0.5 * 2.0, 2.0]
    assert demos.observations[:, 0].tolist() == [0.0, 1.0]
    assert demos.makespans == [7]


def test_demonstrations_are_the_teachers_finished_episodes():
    venv = _venv(reward="makespan")
    venv.seed(3)
    demos = demonstrate(venv, policies.factory("prioritized"), 3, gamma=1.0)
    assert len(demos.makespans) == 3 and all(m is not None for m in demos.makespans)
    # Every row is a real crane row and every action is allowed by its mask.
    assert len(demos) % 2 == 0
    assert demos.masks[np.arange(len(demos)), demos.actions].all()
    assert demos.decisions.any() and (demos.actions[demos.decisions] > 0).any()
    # Undiscounted makespan returns: completion minus the steps left, so the first rows of
    # each episode return completion - makespan and every return lies between.
    completion = MultiCraneEnv("e3s2", n_cranes=2, decisions="task").scenario.reward.completion
    assert demos.returns.max() <= completion - 1 + 1e-6
    assert np.isclose(demos.returns.min(), completion - max(demos.makespans))


def test_progress_counts_every_finished_episode_and_logs_tenths():
    venv = _venv(reward="makespan")
    venv.seed(3)
    seen: list[int] = []
    demos = demonstrate(venv, policies.factory("prioritized"), 3, gamma=1.0,
                        progress=seen.append)  # fmt: skip
    # One call per finished episode, counting up; episodes past the asked number may end
    # in the same round (two copies), and are counted but not kept.
    assert seen[:3] == [1, 2, 3] and seen == list(range(1, len(seen) + 1))
    assert len(demos.makespans) == 3
    lines: list[str] = []
    report = progress_log("run: teacher", 25, lines.append)
    for finished in range(1, 28):
        report(finished)
    counts = [line.split()[2] for line in lines]
    assert counts == ["2/25", "4/25", "6/25", "8/25", "10/25", "12/25", "14/25", "16/25",
                      "18/25", "20/25", "22/25", "24/25", "25/25"]  # fmt: skip
    assert all(line.startswith("run: teacher: ") and line.endswith(" s)") for line in lines)


def test_cloning_makes_the_policy_follow_the_teacher():
    venv = _venv("e3s3")  # random starts: the teacher's choices vary with the layout
    venv.seed(0)
    demos = demonstrate(venv, policies.factory("prioritized"), 8, gamma=0.99)
    model = make_set_model(venv, 0, set_hyperparameters({}), None)
    before = agreement(model.policy, demos)
    history = clone(model.policy, demos, epochs=30, batch_size=64, seed=0)
    assert history[-1]["actor_nll"] < history[0]["actor_nll"]
    assert history[-1]["critic_mse"] < 0.5 * history[0]["critic_mse"]
    assert history[-1]["agreement"] > before + 0.2


def test_a_fit_can_stop_once_it_agrees_with_the_teacher():
    venv = _venv("e3s2", reward="makespan")
    venv.seed(0)
    demos = demonstrate(venv, policies.factory("prioritized"), 2, gamma=0.99)
    model = make_set_model(venv, 0, set_hyperparameters({}), None)
    history = clone(model.policy, demos, epochs=1000, batch_size=64, seed=0, stop_at=1.0)
    # An exact fit, checked every STOP_CHECK epochs, long before the 1,000 allowed.
    assert history[-1]["agreement"] == 1.0
    assert len(history) < 1000 and len(history) % STOP_CHECK == 0
    assert [h["epoch"] for h in history] == list(range(1, len(history) + 1))
    # The same fit without the stop runs every epoch, the same ones first.
    model = make_set_model(venv, 0, set_hyperparameters({}), None)
    full = clone(model.policy, demos, epochs=len(history) + 3, batch_size=64, seed=0)
    assert len(full) == len(history) + 3
    assert [h["actor_nll"] for h in full[: len(history)]] == [h["actor_nll"] for h in history]
    for bad in (0, 1.5, -0.1):
        with pytest.raises(ValueError, match=f"stop_at must be a share in \\(0, 1\\], got {bad}"):
            clone(model.policy, demos, epochs=1, stop_at=bad)


def test_imitation_needs_maskable_ppo_and_a_teacher(tmp_path):
    with pytest.raises(ConfigError, match="needs the multi-agent mode and algo='maskable_ppo'"):
        TrainConfig("e3s2", paper=False, n_cranes=2, algo="ppo", imitate="prioritized")
    with pytest.raises(ConfigError, match="imitate_demos='d.npz': needs imitate"):
        TrainConfig("e3s2", paper=False, n_cranes=2, imitate_demos="d.npz")
    with pytest.raises(ConfigError, match="imitate_stop=1.0: needs imitate"):
        TrainConfig("e3s2", paper=False, n_cranes=2, imitate_stop=1.0)
    for bad in (0, 1.01, True, "1"):
        with pytest.raises(ConfigError, match=f"imitate_stop={bad!r}: must be a share of rows"):
            TrainConfig("e3s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                        imitate="prioritized", imitate_stop=bad)  # fmt: skip
    with pytest.raises(ConfigError, match="reward='makespan': a multi-agent option"):
        TrainConfig("E1S1", reward="makespan")
    cfg = TrainConfig("e3s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                      policy="set", imitate="prioritized")  # fmt: skip
    with pytest.raises(ConfigError, match="pass its policy as teacher"):
        train(cfg, tmp_path / "run", log=lambda *a: None)


def _imitating_cfg(steps, demos=None):
    return TrainConfig("e3s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                       policy="set", imitate="prioritized", imitate_episodes=6,
                       imitate_epochs=15, reward="makespan", shaping=0.0, n_envs=2,
                       total_steps=steps, eval_every=64, eval_episodes=2, checkpoint_every=0,
                       imitate_demos=demos,
                       hyperparams={"n_steps": 16, "batch_size": 64, "n_epochs": 2,
                                    "learning_rate": 1e-5})  # fmt: skip


def test_a_run_starts_from_the_teacher_and_resumes_exactly(tmp_path):
    cfg = _imitating_cfg(256, demos=str(tmp_path / "demos.npz"))
    teacher = policies.factory("prioritized")
    ref = train(cfg, tmp_path / "ref", teacher=teacher, log=lambda *a: None)
    assert (tmp_path / "demos.npz").exists()
    imitation = ref["imitation"]
    assert imitation["teacher"] == "prioritized" and imitation["episodes"] == 6
    assert imitation["decision_rows"] > 0 and imitation["teacher_finished"] == 6
    # The curve's first point is the cloned policy, before any PPO update: it finishes.
    assert ref["curve"][0]["step"] == 0 and ref["curve"][0]["success_rate"] == 1.0
    # Cut after the imitation and the first updates, resumed: the same parameters.
    # (The second run reads the first one's demonstrations file.)
    said = []
    assert train(cfg, tmp_path / "cut", teacher=teacher, stop_at=128, log=said.append) is None
    assert any("demonstrations from" in line for line in said)
    resumed = train(cfg, tmp_path / "cut", teacher=teacher, log=lambda *a: None)
    timeless = lambda d: {k: v for k, v in d.items() if "seconds" not in k}  # noqa: E731
    assert resumed["sessions"] == 2
    assert timeless(resumed["imitation"]) == timeless(imitation)  # imitated once, before the cut
    a, _ = load_run(tmp_path / "ref")
    b, _ = load_run(tmp_path / "cut")
    sa, sb = a.policy.state_dict(), b.policy.state_dict()
    assert all(th.equal(sa[k], sb[k]) for k in sa)


def test_demonstrations_file_round_trip_and_refusal(tmp_path):
    from multicrane.training.imitation import DemonstrationsError, load, save

    venv = _venv("e2s2")
    venv.seed(1)
    demos = demonstrate(venv, policies.factory("greedy"), 2, gamma=0.9)
    meta = {"teacher": "greedy", "scenario": "e2s2", "episodes": 2, "seed": 5}
    path = tmp_path / "demos" / "e2s2.npz"
    save(demos, path, meta)
    back = load(path, {**meta, "seed": 6})  # another run seed may reuse them
    for name in ("observations", "masks", "actions", "returns"):
        assert np.array_equal(getattr(back, name), getattr(demos, name))
    assert back.makespans == demos.makespans
    with pytest.raises(DemonstrationsError, match="teacher: file 'greedy' != run 'lookahead'"):
        load(path, {**meta, "teacher": "lookahead"})
    # Exclusive: a file already there (another run's) is left as it is.
    before = path.read_bytes()
    assert not save(demonstrate(venv, policies.factory("prioritized"), 2, gamma=0.9), path,
                    meta, exclusive=True)  # fmt: skip
    assert path.read_bytes() == before and sorted(path.parent.iterdir()) == [path]
    assert save(demos, tmp_path / "new.npz", meta, exclusive=True)
    assert (tmp_path / "new.npz").read_bytes() == before
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(DemonstrationsError, match="junk.npz: not a demonstrations file"):
        load(tmp_path / "junk.npz", meta)


def test_a_run_whose_file_appears_meanwhile_clones_the_files_episodes(tmp_path):
    # Two runs of one setting start at once, both find no file and play the teacher: the
    # first to finish writes the file; the second leaves it and clones the file's episodes.
    first, second = tmp_path / "first.npz", tmp_path / "second.npz"
    quiet = lambda *a: None  # noqa: E731
    teacher = policies.factory("prioritized")
    # e3s3 starts at random: the two seeds' teacher episodes differ (rows, makespans).
    cfg = lambda demos, seed: dataclasses.replace(  # noqa: E731
        _imitating_cfg(64, demos=str(demos)), scenario="e3s3", seed=seed)
    ref = train(cfg(first, 1), tmp_path / "ref", teacher=teacher, log=quiet)

    def racing_teacher(*args, **kwargs):  # the other run's file lands while this one plays
        if not second.exists():
            shutil.copyfile(first, second)
        return teacher(*args, **kwargs)

    said: list[str] = []
    run = train(cfg(second, 0), tmp_path / "run", teacher=racing_teacher, log=said.append)
    assert second.read_bytes() == first.read_bytes()
    assert any("written by another run meanwhile" in str(line) for line in said)
    keys = ("teacher_makespan_mean", "rows", "decision_rows")
    assert {k: run["imitation"][k] for k in keys} == {k: ref["imitation"][k] for k in keys}
