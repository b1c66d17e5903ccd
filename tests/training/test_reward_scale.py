"""The set policy's reward scaled per site: the site's static work, and the scaled rewards."""

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

from multicrane.envs.crane_env import MultiCraneEnv  # noqa: E402
from multicrane.training import TrainConfig  # noqa: E402
from multicrane.training.config import ConfigError  # noqa: E402
from multicrane.training.set_obs import SetLimits  # noqa: E402
from multicrane.training.set_vec_env import SetVecEnv, site_work  # noqa: E402

SITES = (("e2s2", 2), ("frame2-3c", 3), ("hall-4c", 4))


def reference_work(env: MultiCraneEnv) -> float:
    """The definition, one component, task and crane at a time."""
    book = env.mode.task_book()
    total = 0
    for comp in range(env.sim.site.n_components):
        lengths = [
            int(book.static_len[k, p])
            for p in np.flatnonzero(book.tasks.comp == comp)
            for k in range(len(env.possible_agents))
            if book.static_ok[k, p]
        ]
        total += min(lengths) if lengths else 0
    return max(1.0, total / len(env.possible_agents))


@pytest.mark.parametrize("name,cranes", SITES)
@pytest.mark.parametrize("seed", [0, 5])
def test_site_work_follows_its_definition(name, cranes, seed):
    env = MultiCraneEnv(name, n_cranes=cranes, decisions="task", reward="makespan")
    env.reset(seed=seed)
    work = site_work(env)
    assert work == pytest.approx(reference_work(env)) and work > 1


def _venv(scale: str) -> SetVecEnv:
    make = lambda i: MultiCraneEnv("frame2-3c", n_cranes=3, decisions="task",  # noqa: E731
                                   reward="makespan")  # fmt: skip
    venv = SetVecEnv(make, 2, SetLimits(29, 4, 289), reward_scale=scale)
    venv.seed(3)
    venv.reset()
    return venv


def test_scaled_rewards_are_the_rewards_over_the_work_and_statistics_stay_raw():
    plain, scaled = _venv("none"), _venv("site")
    works = [site_work(env) for env in scaled.envs]
    rng = np.random.default_rng(0)
    episodes = 0
    for _ in range(300):
        masks = plain.action_masks()
        assert np.array_equal(masks, scaled.action_masks())
        actions = np.array([rng.choice(np.flatnonzero(m)) for m in masks])
        for venv in (plain, scaled):
            venv.step_async(actions)
        works_now = works
        _, r_plain, d_plain, i_plain = plain.step_wait()
        _, r_scaled, d_scaled, i_scaled = scaled.step_wait()
        assert np.array_equal(d_plain, d_scaled)
        expected = r_plain / np.repeat(works_now, 4).astype(np.float32)
        np.testing.assert_allclose(r_scaled, expected, rtol=1e-5)
        for a, b in zip(i_plain, i_scaled, strict=True):
            if "episode" in a:
                episodes += 1
                assert a["episode"]["r"] == b["episode"]["r"]  # the environment's reward
        works = [site_work(env) for env in scaled.envs]  # after a reset, the new episode's
    assert episodes >= 2


def test_reward_scale_is_checked():
    with pytest.raises(ValueError, match="reward_scale='sites'"):
        SetVecEnv(lambda i: MultiCraneEnv("e2s2", n_cranes=2, decisions="task"), 1,
                  SetLimits(29, 4, 289), reward_scale="sites")  # fmt: skip
    with pytest.raises(ConfigError, match="reward_scale='site'"):
        TrainConfig("e2s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                    reward_scale="site")  # fmt: skip


def test_a_demonstrations_file_of_the_raw_reward_is_refused_by_a_scaled_run(tmp_path):
    """The teacher's rows carry returns in the run's reward: raw and scaled files differ."""
    import policies
    from multicrane.training import train
    from multicrane.training.imitation import DemonstrationsError

    def cfg(scale):
        return TrainConfig("e3s2", paper=False, n_cranes=2, decisions="task",
                           algo="maskable_ppo", policy="set", imitate="prioritized",
                           imitate_episodes=2, imitate_epochs=1, reward="makespan", shaping=0.0,
                           n_envs=2, total_steps=64, eval_every=0, eval_episodes=1,
                           checkpoint_every=0, imitate_demos=str(tmp_path / "demos.npz"),
                           reward_scale=scale, hyperparams={"n_steps": 8, "batch_size": 16,
                                                            "n_epochs": 1})  # fmt: skip

    teacher = policies.factory("prioritized")
    train(cfg("none"), tmp_path / "raw", teacher=teacher, log=lambda *a: None)
    with pytest.raises(DemonstrationsError, match="reward_scale: file None != run 'site'"):
        train(cfg("site"), tmp_path / "scaled", teacher=teacher, log=lambda *a: None)
