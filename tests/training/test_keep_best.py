"""``TrainConfig.keep_best``: the final model is the curve point with the best validation
return, chosen on validation episodes that are not the evaluation episodes."""

from __future__ import annotations

import pytest
import torch as th
from conftest import one_torch_thread  # noqa: F401 (fixture)

from multicrane.training import ConfigError, TrainConfig, train
from multicrane.training.model_policy import load_run
from multicrane.training.seeding import VALIDATION_FIRST, evaluation_seeds

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def test_validation_seeds_are_not_evaluation_seeds():
    assert not set(evaluation_seeds(1000)) & set(evaluation_seeds(1000, VALIDATION_FIRST))


@pytest.mark.parametrize(
    ("options", "message"),
    [({"eval_every": 0}, "needs eval_every > 0"), ({"keep_best": 1}, "must be True or False")],
)
def test_keep_best_needs_curve_points(options, message):
    with pytest.raises(ConfigError, match=message):
        TrainConfig("E2S2", algo="ppo", **{"keep_best": True, "eval_every": 100, **options})


def test_the_final_model_is_the_best_validation_point(tmp_path, monkeypatch):
    from sb3_contrib import MaskablePPO

    from multicrane.training import trainer

    real = trainer.evaluate_model

    def first_is_best(model, *args, validation=False, **kwargs):
        episodes, summary = real(model, *args, validation=validation, **kwargs)
        if validation:  # later points score worse: the final model must be the first one
            summary = {**summary, "return_mean": -float(model.num_timesteps)}
        return episodes, summary

    monkeypatch.setattr(trainer, "evaluate_model", first_is_best)

    cfg = TrainConfig("e2s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                      policy="set", n_envs=2, total_steps=192, eval_every=64, eval_episodes=2,
                      checkpoint_every=0, keep_best=True, reward="makespan",
                      hyperparams={"n_steps": 16, "batch_size": 32, "n_epochs": 2,
                                   "learning_rate": 3e-3})  # fmt: skip
    result = train(cfg, tmp_path / "run", log=lambda *a: None)
    curve = result["curve"]
    assert len(curve) >= 3 and all("validation_return_mean" in p for p in curve)
    values = [p["validation_return_mean"] for p in curve]
    first_best = curve[values.index(max(values))]
    assert result["best"] == {"step": first_best["step"],
                              "validation_return_mean": max(values)}  # fmt: skip
    assert result["best"]["step"] == 0
    final, _ = load_run(tmp_path / "run")
    best = MaskablePPO.load(tmp_path / "run" / "best.zip", device="cpu")
    a, b = final.policy.state_dict(), best.policy.state_dict()
    assert all(th.equal(a[k], b[k]) for k in a)
    # ... which is the untrained network the same seed builds, not the trained one.
    from multicrane.training.set_training import make_set_model, make_set_vec_env
    from multicrane.training.set_training import set_hyperparameters as params

    fresh = make_set_model(make_set_vec_env(cfg, 2, 0.99, workers=1), cfg.seed,
                           params(cfg.hyperparams), None).policy.state_dict()  # fmt: skip
    assert all(th.equal(a[k], fresh[k]) for k in a)


def test_curriculum_validation_sites_are_never_training_or_test_sites():
    from multicrane.training import curriculum as cur

    valid = cur.validation_pool("grow", 10)
    pools = set().union(
        *(cur.stage_pool("grow", i) for i in range(len(cur.CURRICULA["grow"].stages)))
    )
    assert len(valid) == 10 and not set(valid) & pools
    assert all(cur.VALIDATION_START <= s < 1_000_000 for s in valid)  # held-out sets: 1e6+
