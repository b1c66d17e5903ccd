"""The set-based shared policy: padding, permutation invariance and equivariance, size
independence (one network on sites of three sizes), masking (no illegal task is ever chosen,
property-based), the padded vector environment, the curriculum and its exact resume.

Budgets are tiny: these tests check the machinery, not learning.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

import torch as th  # noqa: E402
from conftest import play_legal  # noqa: E402
from gymnasium import spaces  # noqa: E402
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from multicrane.envs.crane_env import MultiCraneEnv  # noqa: E402
from multicrane.training import TrainConfig, train  # noqa: E402
from multicrane.training import curriculum as cur  # noqa: E402
from multicrane.training.config import ConfigError  # noqa: E402
from multicrane.training.model_policy import SetModelPolicy, load_run  # noqa: E402
from multicrane.training.set_obs import HEADER, N_COMP, N_TASK, Padder, SetLimits, union  # noqa: E402
from multicrane.training.set_policy import BLOCKED, SetExtractor  # noqa: E402
from multicrane.training.set_training import make_set_model, set_hyperparameters  # noqa: E402
from multicrane.training.set_vec_env import SetVecEnv  # noqa: E402

SITES = (("e2s2", 2), ("frame2-3c", 3), ("hall-4c", 4))  # three sizes


pytestmark = pytest.mark.usefixtures("one_torch_thread")


def task_env(name: str, cranes: int) -> MultiCraneEnv:
    return MultiCraneEnv(name, n_cranes=cranes, decisions="task")


def tables(env, seed=0, steps=0):
    """Flat observations and masks of every crane after ``steps`` greedy-ish rounds."""
    obs, _ = env.reset(seed=seed)
    for _ in range(steps):
        acts = {a: int(np.flatnonzero(obs[a]["action_mask"])[-1]) for a in env.agents}
        obs, *_ = env.step(acts)
    return obs


def extractor(limits: SetLimits, heads: int, seed: int = 0) -> SetExtractor:
    th.manual_seed(seed)
    ex = SetExtractor(spaces.Box(0, 1e4, (limits.size,)), limits, dim=32, heads=heads)
    return ex.eval()


def features(ex: SetExtractor, batch: np.ndarray) -> np.ndarray:
    with th.no_grad():
        return ex(th.as_tensor(np.asarray(batch, dtype=np.float32))).numpy()


LIM = SetLimits(29, 4, 289)


@pytest.fixture(scope="module")
def hall():
    env = task_env("hall-4c", 4)
    obs = tables(env, steps=3)
    pad = Padder(env.observation_layout, SetLimits.of(env.observation_layout))
    batch = np.stack([pad.pad(obs[a]["observation"]) for a in env.possible_agents])
    return env, batch


# -- padding -------------------------------------------------------------------------------------


def test_padding_at_the_limits_is_the_observation_itself(hall):
    env, batch = hall
    obs = tables(env, steps=3)
    assert np.array_equal(batch[0, HEADER:], obs["crane_0"]["observation"])
    assert batch[0, :HEADER].tolist() == [29, 4, 289]


def test_limits_name_the_table_that_does_not_fit():
    env = task_env("hall-4c", 4)
    with pytest.raises(ValueError, match="289 tasks exceed the policy's limit of 100"):
        SetLimits(40, 4, 100).check(env.observation_layout)
    with pytest.raises(ValueError, match="components=0"):
        SetLimits(0, 1, 1)


@pytest.mark.parametrize("heads", [0, 4])
def test_padding_rows_do_not_change_the_output(hall, heads):
    env, batch = hall
    small, big = SetLimits.of(env.observation_layout), SetLimits(40, 6, 400)
    a, b = extractor(small, heads), extractor(big, heads)
    b.load_state_dict(a.state_dict())  # the weights do not depend on the limits
    pad = Padder(env.observation_layout, big)
    obs = tables(env, steps=3)
    padded = np.stack([pad.pad(obs[x]["observation"]) for x in env.possible_agents])
    fa, fb = features(a, batch), features(b, padded)
    P = small.tasks
    np.testing.assert_allclose(fa[:, : 1 + P], fb[:, : 1 + P], atol=1e-5)
    assert np.all(fb[:, 1 + P : big.n_actions] == BLOCKED)
    np.testing.assert_allclose(fa[:, 1 + P :], fb[:, big.n_actions :], atol=1e-5)  # g and s


# -- permutations --------------------------------------------------------------------------------


def _split(batch, limits):
    out = {}
    for name, (a, b, shape) in limits.slices().items():
        out[name] = batch[:, a:b].reshape(len(batch), *shape).copy()
    return out


def _join(header, t):
    return np.concatenate([header] + [t[k].reshape(len(header), -1) for k in t], axis=1)


@pytest.mark.parametrize("heads", [0, 4])
def test_permuting_components_leaves_every_logit(hall, heads):
    _, batch = hall
    t = _split(batch, LIM)
    C = LIM.components
    perm = np.random.default_rng(1).permutation(C)  # new row i holds old row perm[i]
    inv = np.argsort(perm)
    t["components"] = t["components"][:, perm]
    old = np.rint(t["tasks"][:, :, 0] * (C - 1)).astype(int)
    t["tasks"][:, :, 0] = inv[old] / (C - 1)
    ex = extractor(LIM, heads)
    np.testing.assert_allclose(features(ex, _join(batch[:, :HEADER], t)), features(ex, batch),
                               atol=1e-4)  # fmt: skip


@pytest.mark.parametrize("heads", [0, 4])
def test_permuting_tasks_permutes_the_logits(hall, heads):
    _, batch = hall
    t = _split(batch, LIM)
    perm = np.random.default_rng(2).permutation(LIM.tasks)
    t["tasks"] = t["tasks"][:, perm]
    ex = extractor(LIM, heads)
    fa, fb = features(ex, batch), features(ex, _join(batch[:, :HEADER], t))
    np.testing.assert_allclose(fb[:, 1 : 1 + LIM.tasks], fa[:, 1 + perm], atol=1e-4)
    np.testing.assert_allclose(fb[:, 0], fa[:, 0], atol=1e-4)


@pytest.mark.parametrize("heads", [0, 4])
def test_permuting_cranes_leaves_each_cranes_output(hall, heads):
    _, batch = hall
    t = _split(batch, LIM)
    perm = np.array([2, 0, 3, 1])
    t["cranes"] = t["cranes"][:, perm]
    t["components"][:, :, N_COMP:] = t["components"][:, :, N_COMP + perm]
    ex = extractor(LIM, heads)
    np.testing.assert_allclose(features(ex, _join(batch[:, :HEADER], t)), features(ex, batch),
                               atol=1e-4)  # fmt: skip


# -- masking -------------------------------------------------------------------------------------


@settings(max_examples=25, deadline=None)
@given(st.data())
def test_no_illegal_task_ever_has_a_finite_logit(hall, data):
    """Whatever the allowed pattern, a task that is not allowed gets ``BLOCKED`` and the
    greedy choice of the logits alone (no mask) is wait or an allowed task."""
    _, batch = hall
    t = _split(batch[:1], LIM)
    allowed = np.array(data.draw(st.lists(st.booleans(), min_size=LIM.tasks,
                                          max_size=LIM.tasks)))  # fmt: skip
    t["tasks"][0, :, N_TASK - 1] = allowed
    f = features(extractor(LIM, 0), _join(batch[:1, :HEADER], t))[0]
    logits = f[1 : 1 + LIM.tasks]
    assert np.all(logits[~allowed] == BLOCKED)
    assert np.all(logits[allowed] > BLOCKED / 2)
    choice = int(np.argmax(f[: 1 + LIM.tasks]))
    assert choice == 0 or allowed[choice - 1]


def _model(limits, n_copies=1, heads=0, **policy_kwargs):
    name, cranes = SITES[0]
    venv = SetVecEnv(lambda i: task_env(name, cranes), n_copies, limits)
    hp = set_hyperparameters(
        {
            "n_steps": 8,
            "batch_size": 16,
            "policy_kwargs": {"features_extractor_kwargs": {"heads": heads}, **policy_kwargs},
        }
    )
    return make_set_model(venv, 0, hp, None), venv  # fmt: skip


@pytest.mark.parametrize("heads", [0, 4])
def test_one_network_plays_three_site_sizes_legally(heads):
    envs = [task_env(n, k) for n, k in SITES]
    limits = union(e.observation_layout for e in envs)
    model, _ = _model(limits, heads=heads)
    for env in envs:
        policy = SetModelPolicy(model, env, deterministic=False)
        play_legal(env, policy, seed=3, steps=25, label=env.scenario.name)


# -- the vector environment ----------------------------------------------------------------------


def test_spare_rows_only_wait_and_end_every_step():
    limits = SetLimits(29, 4, 289)
    venv = SetVecEnv(lambda i: task_env("e2s2", 2), 2, limits)
    venv.seed(0)
    obs = venv.reset()
    assert obs.shape == (8, limits.size)
    masks = venv.action_masks()
    for copy in range(2):
        spare = [copy * 4 + 2, copy * 4 + 3]
        assert np.all(masks[spare, 0]) and not np.any(masks[spare, 1:])
        assert masks[copy * 4 : copy * 4 + 2].sum() > 2  # the real cranes have tasks
    venv.step_async(np.zeros(8, dtype=int))
    _, rewards, dones, _ = venv.step_wait()
    assert np.all(dones[[2, 3, 6, 7]]) and np.all(rewards[[2, 3, 6, 7]] == 0)


def test_set_config_is_checked():
    with pytest.raises(ConfigError, match="policy='set' needs"):
        TrainConfig("hall-4c", paper=False, n_cranes=4, policy="set")
    with pytest.raises(ConfigError, match="curriculum='nope'"):
        TrainConfig("set:train", paper=False, decisions="task", algo="maskable_ppo",
                    policy="set", curriculum="nope")  # fmt: skip
    with pytest.raises(ConfigError, match="set_limits"):
        TrainConfig("hall-4c", paper=False, decisions="task", algo="maskable_ppo",
                    policy="set", set_limits={"components": 3})  # fmt: skip


# -- the curriculum ------------------------------------------------------------------------------


@pytest.fixture
def tiny_curriculum(monkeypatch):
    plan = cur.Plan(
        stages=(cur.Stage((1, 8), min_episodes=2, max_episodes=3),
                cur.Stage((9, 13), max_episodes=10**9)),
        limits=SetLimits(13, 4, 169), pool=2, window=2,
    )  # fmt: skip
    monkeypatch.setitem(cur.CURRICULA, "tiny-test", plan)
    cur.stage_pool.cache_clear()
    yield "tiny-test"
    cur.stage_pool.cache_clear()


def test_stage_pools_grow_and_use_train_seeds_only(tiny_curriculum):
    small, big = cur.stage_pool(tiny_curriculum, 0), cur.stage_pool(tiny_curriculum, 1)
    assert len(small) == len(big) == 2 and not set(small) & set(big)
    assert all(s < 1_000_000 for s in small + big)  # never a held-out seed
    sizes = [cur._site(s).n_components for s in small + big]
    assert max(sizes[:2]) <= 8 < min(sizes[2:])


def _tiny_cfg(name, steps):
    return TrainConfig("set:train", paper=False, decisions="task", algo="maskable_ppo",
                       policy="set", curriculum=name, n_envs=2, total_steps=steps,
                       eval_episodes=1, checkpoint_every=0, max_steps=60,
                       hyperparams={"n_steps": 8, "batch_size": 32, "n_epochs": 2})  # fmt: skip


def test_a_stage_without_enough_sites_is_refused(monkeypatch):
    plan = cur.Plan(stages=(cur.Stage((1, 5)),), limits=SetLimits(13, 4, 169), pool=2)
    monkeypatch.setitem(cur.CURRICULA, "empty-test", plan)
    monkeypatch.setattr(cur, "SCAN", 50)
    cur.stage_pool.cache_clear()
    with pytest.raises(ValueError, match="only 0 of 2 train sites"):
        cur.stage_pool("empty-test", 0)
    cur.stage_pool.cache_clear()


def test_curriculum_run_moves_on_and_resumes_exactly(tiny_curriculum, tmp_path):
    cfg = _tiny_cfg(tiny_curriculum, 64 * 6)
    ref = train(cfg, tmp_path / "ref", log=lambda *a: None)
    assert ref["curriculum"]["stage"] == 1, ref["curriculum"]
    assert ref["final_episodes"][0]["site"].startswith("test-small/")
    assert train(cfg, tmp_path / "cut", stop_at=128, log=lambda *a: None) is None
    resumed = train(cfg, tmp_path / "cut", log=lambda *a: None)
    assert resumed["sessions"] == 2 and resumed["steps"] == ref["steps"]
    a, _ = load_run(tmp_path / "ref")
    b, _ = load_run(tmp_path / "cut")
    sa, sb = a.policy.state_dict(), b.policy.state_dict()
    assert all(th.equal(sa[k], sb[k]) for k in sa)
    assert resumed["curriculum"] == ref["curriculum"]


def test_a_copy_keeps_few_environments_and_builds_the_rest_again(tiny_curriculum, tmp_path,
                                                                 monkeypatch):  # fmt: skip
    """Built again after eviction, a site plays the same episodes: the same parameters."""
    cfg = _tiny_cfg(tiny_curriculum, 64 * 3)
    train(cfg, tmp_path / "kept", log=lambda *a: None)
    monkeypatch.setattr(cur, "ENVS_PER_COPY", 1)
    sites = cur.SiteCurriculum(tiny_curriculum, 1)
    rng = np.random.default_rng(0)
    for _ in range(6):
        env = sites.next_env(0, rng)
        assert list(sites._envs[0].values()) == [env]  # only the last site's environment
    train(cfg, tmp_path / "rebuilt", log=lambda *a: None)
    a, _ = load_run(tmp_path / "kept")
    b, _ = load_run(tmp_path / "rebuilt")
    sa, sb = a.policy.state_dict(), b.policy.state_dict()
    assert all(th.equal(sa[k], sb[k]) for k in sa)


def test_worker_processes_give_the_same_rows_as_one_process():
    from multicrane.training.set_training import _Blocks
    from multicrane.training.set_workers import WorkerSetVecEnv

    limits = {"components": 4, "cranes": 3, "tasks": 6}  # a spare row per copy
    cfg = TrainConfig("e2s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                      policy="set", set_limits=limits)  # fmt: skip
    one = _Blocks(cfg, 0.99)(3)
    many = WorkerSetVecEnv(_Blocks(cfg, 0.99), 3, 2)
    try:
        rng = np.random.default_rng(0)
        for venv in (one, many):
            venv.seed(7)
        a, b = one.reset(), many.reset()
        assert np.array_equal(a, b)
        for _ in range(40):
            masks = one.action_masks()
            assert np.array_equal(masks, many.action_masks())
            acts = (rng.random(masks.shape) * masks).argmax(1)
            ra, rb = one.step(acts), many.step(acts)
            for x, y in zip(ra[:3], rb[:3], strict=True):
                assert np.array_equal(x, y)
            assert [i.get("episode", {}).get("r") for i in ra[3]] == [
                i.get("episode", {}).get("r") for i in rb[3]
            ]
    finally:
        many.close()


def test_a_policy_trained_on_small_limits_plays_a_bigger_site():
    small = task_env("e2s2", 2)
    model, _ = _model(SetLimits.of(small.observation_layout))
    env = task_env("hall-4c", 4)
    policy = SetModelPolicy(model, env)  # resized to hall-4c, same weights
    assert policy.actor.limits.tasks >= 289
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        acts = policy(obs)
        assert all(obs[a]["action_mask"][x] for a, x in acts.items())
        obs, *_ = env.step(acts)


def test_marl_bench_latency_command(capsys):
    from multicrane.cli import main

    assert main(["marl-bench", "--latency", "--scenario", "e2s2", "--cranes", "2",
                 "--rounds", "12"]) == 0  # fmt: skip
    assert "ms CPU time" in capsys.readouterr().out
    assert main(["marl-bench"]) == 2


def test_marl_bench_throughput_settings():
    from multicrane.cli.marl_bench import throughput

    r = throughput("e2s2", 2, 64, "after-makespan")
    assert r["setting"] == "after-makespan" and r["rows"] >= r["rows_per_update"] > 0
    assert 0 < r["update_share"] < 1
    with pytest.raises(ValueError, match="one of before, after"):
        throughput("e2s2", 2, 64, "sideways")


def test_train_command_options_make_a_set_config():
    from multicrane.cli import build_parser
    from multicrane.cli.train import build_config

    parser = build_parser()
    args = parser.parse_args(["train", "--scenario", "set:train", "--curriculum", "grow",
                              "--workers", "2"])  # fmt: skip
    cfg = build_config(args)
    assert (cfg.scenario, cfg.decisions, cfg.policy, cfg.curriculum, cfg.workers) == (
        "set:train", "task", "set", "grow", 2)  # fmt: skip
    args = parser.parse_args(["train", "--scenario", "hall-4c", "--cranes", "4", "--decisions",
                              "task", "--policy", "set", "--set-limits", "32,4,320"])  # fmt: skip
    cfg = build_config(args)
    assert cfg.set_limits == {"components": 32, "cranes": 4, "tasks": 320}
    with pytest.raises(ValueError, match="--set-limits '3,4'"):
        build_config(parser.parse_args(["train", "--scenario", "hall-4c", "--policy", "set",
                                        "--set-limits", "3,4"]))  # fmt: skip
    with pytest.raises(ValueError, match="--curriculum trains on --scenario set:train"):
        build_config(parser.parse_args(["train", "--scenario", "e2s2", "--curriculum", "grow"]))


def test_an_untrained_greedy_policy_does_not_wait_forever():
    env = task_env("hall-4c", 4)
    model, _ = _model(SetLimits.of(env.observation_layout))
    policy = SetModelPolicy(model, env)
    obs, _ = env.reset(seed=0)
    acts = policy(obs)
    assert any(x != 0 for x in acts.values())  # idle cranes with tasks take one


def test_an_unshared_critic_reads_the_summary_and_never_moves_the_actor(hall):
    _, batch = hall
    model, venv = _model(LIM, share_features_extractor=False)
    policy = model.policy
    policy.claim_rows = venv.n_agents  # as the training run samples (claims.py)
    actor, critic = policy.pi_features_extractor, policy.vf_features_extractor
    assert actor is policy.features_extractor and critic is not actor
    assert critic.summary_only and not actor.summary_only
    obs = th.as_tensor(batch.astype(np.float32))
    critic.summary_only = False  # the full output's summary is what the critic reads
    full = critic(obs).detach()
    critic.summary_only = True
    n = LIM.n_actions
    assert th.equal(critic(obs)[:, n:], full[:, n:]) and not critic(obs)[:, :n].any()
    policy.predict_values(obs).sum().backward()  # a critic-only loss
    assert all(p.grad is None for p in actor.parameters())
    assert any(p.grad is not None and p.grad.abs().sum() > 0 for p in critic.parameters())
    before = [p.detach().clone() for p in critic.parameters()]
    model.learn(32)  # PPO's rollouts (claims in turn) and updates run with two extractors
    assert any(not th.equal(a, p) for a, p in zip(before, critic.parameters(), strict=True))
