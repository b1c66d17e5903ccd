"""The leaderboard's kinds of entries (planner, learned, search, submitted) and their order,
and a training run evaluated on the suite under a readable name with its training config."""

from __future__ import annotations

import json

import pytest
from conftest import one_torch_thread  # noqa: F401 (fixture)

from multicrane.cli import main
from multicrane.suite.manifest import MANIFEST, manifest_text, read_manifest
from multicrane.suite.page import RESULTS_DIR, SEARCH, entry_kind, leaderboard
from multicrane.suite.results import read_results

PLANNERS = ("prioritized", "greedy")


def _results(policy: str, spans: list[int], **extra) -> dict:
    v1 = read_manifest("v1")
    ids = [i.id for i in v1.track("small")]
    entries = [{"id": k, "makespan": m, "seconds": 1.0} for k, m in zip(ids, spans, strict=True)]
    return {"track": "small", "policy": policy, "decisions": "task", **extra,
            "instances": entries}  # fmt: skip


def test_entry_kind_tells_planners_learned_policies_and_the_search_apart():
    training = {"run": "r", "config": {"algo": "maskable_ppo"}}
    assert entry_kind(_results("greedy", [1] * 8), PLANNERS) == "planner"
    assert entry_kind(_results("prioritized:rank=nearest", [1] * 8), PLANNERS) == "planner"
    assert entry_kind(_results("ppo-zero-shot", [1] * 8, training=training), PLANNERS) == (
        "learned"
    )
    learned_order = "prioritized:rank=chain,scorer=order-es21-s0"
    assert entry_kind(_results(learned_order, [1] * 8), PLANNERS) == "learned"
    assert entry_kind(_results("prioritized:rank=chain,", [1] * 8), PLANNERS) == "planner"
    assert entry_kind(_results(SEARCH, [1] * 8), PLANNERS) == "search"
    assert entry_kind(_results("mine", [1] * 8), PLANNERS) == "submitted"


def test_planners_then_learned_policies_come_first_whatever_their_gap():
    v1 = read_manifest("v1")
    bounds = {i.id: {"bound": 100, "status": "optimal", "wall_s": 1.0} for i in v1.track("small")}
    training = {"run": "r", "config": {}}
    entries = {  # policy -> (makespan on every instance, extra keys)
        "submitted-best": (100, {}), SEARCH: (101, {}), "ppo-b": (130, {"training": training}),
        "ppo-a": (120, {"training": training}), "greedy": (150, {}), "prioritized": (110, {}),
    }  # fmt: skip
    collected = [{"path": v1.folder / RESULTS_DIR / f"small-{name}.json",
                  "results": _results(name, [span] * 8, **extra)}
                 for name, (span, extra) in entries.items()]  # fmt: skip
    page = leaderboard(v1, collected, {}, bounds, first=PLANNERS)
    section = page.split("## Track `small`")[1].split("## Track")[0]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    order = [row.split("`")[1] for row in rows]
    assert order == ["prioritized", "greedy", "ppo-a", "ppo-b", SEARCH, "submitted-best"]
    kinds = [row.rstrip(" |").rsplit("| ", 1)[1] for row in rows]
    assert kinds == ["planner", "planner", "learned", "learned", "search", "submitted"]
    assert "| `ppo-a` | task | 8/8 | 120.0 | +20.0 % |" in section


@pytest.fixture(scope="module")
def one_instance(tmp_path_factory):
    """A test version: the shipped small-01 (13 components, 3 cranes, no events) as track
    ``one``."""
    folder = tmp_path_factory.mktemp("one-suite")
    shipped = read_manifest("v1")
    row = {**shipped.get("small-01").row(), "track": "one"}
    target = folder / row["file"]
    target.parent.mkdir(parents=True)
    target.write_bytes((shipped.folder / row["file"]).read_bytes())
    (folder / MANIFEST).write_text(manifest_text("one", "a test version", [row]))
    return folder


@pytest.mark.usefixtures("one_torch_thread")
def test_a_training_run_is_entered_by_name_with_its_training_config(one_instance, tmp_path,
                                                                   capsys):  # fmt: skip
    from multicrane.training import TrainConfig, train

    cfg = TrainConfig("e2s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                      policy="set", n_envs=2, total_steps=32, eval_episodes=1,
                      checkpoint_every=0, reward="makespan",
                      hyperparams={"n_steps": 16, "batch_size": 32, "n_epochs": 1})  # fmt: skip
    run = tmp_path / "tiny-run"
    train(cfg, run, log=lambda *a: None)
    out = tmp_path / "one-learned.json"
    argv = ["suite", "evaluate", str(one_instance), "--track", "one", "--policy", str(run),
            "--name", "ppo-tiny", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    data = read_results(out)
    assert (data["policy"], data["decisions"]) == ("ppo-tiny", "task")
    assert data["training"] == {"run": "tiny-run",
                                "config": json.loads((run / "config.json").read_text())}
    assert entry_kind(data, PLANNERS) == "learned"
    assert main(["suite", "verify", str(out), "--suite", str(one_instance)]) == 0
    assert "verified (1 instances of track one, ppo-tiny)" in capsys.readouterr().out
    default = tmp_path / "default.json"  # without --name: the algorithm and the run's name
    assert main(argv[:-4] + ["--out", str(default)]) == 0
    assert read_results(default)["policy"] == "maskable_ppo (tiny-run)"
