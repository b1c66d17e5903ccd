"""``tools/ppo_update_replay.py``: a captured PPO update replayed "as run" lands on the
parameters the run itself reached, and its variants change what they name."""

from __future__ import annotations

import pytest
from conftest import load_tool, one_torch_thread  # noqa: F401 (fixture)

pytest.importorskip("sb3_contrib")


pytestmark = pytest.mark.usefixtures("one_torch_thread")

RUN = ["--scenario", "e2s2", "--cranes", "2", "--decisions", "task", "--policy", "set",
       "--reward", "makespan", "--shaping", "0", "--set", "n_steps=8", "--set",
       "batch_size=64", "--set", "learning_rate=1e-3", "--steps", "4096", "--eval-every", "0",
       "--checkpoint-every", "0", "--threads", "1", "--seed", "3"]  # fmt: skip


@pytest.fixture(scope="module")
def captured(tmp_path_factory):
    tool = load_tool("ppo_update_replay")
    out = tmp_path_factory.mktemp("updates")
    with pytest.raises(SystemExit) as stop:  # the run stops after its last capture
        tool.main(["capture", str(out), "--at", "256,384", "--", *RUN, "--out",
                   str(out / "run")])  # fmt: skip
    assert stop.value.code == 0
    return tool, out


def test_the_replayed_update_reaches_the_runs_next_parameters(captured):
    tool, out = captured
    from sb3_contrib import MaskablePPO

    model, figures = tool.replay_once(out / "256", {})
    reached = MaskablePPO.load(out / "384" / "model.zip", device="cpu").policy.state_dict()
    before = MaskablePPO.load(out / "256" / "model.zip", device="cpu").policy.state_dict()
    after = model.policy.state_dict()
    moved = max(float((after[k] - before[k]).abs().max()) for k in after)
    off = max(float((after[k] - reached[k]).abs().max()) for k in after)
    assert moved > 1e-4 and off < 1e-6  # the update moved it; the replay is the run's own
    assert figures["kl_mean"] > 0 and figures["kl_max"] >= figures["kl_mean"]
    assert 0 <= figures["greedy_changed"] <= 1


def test_a_variant_changes_the_update(captured, capsys):
    tool, out = captured
    _, still = tool.replay_once(out / "256", {"lr": 0.0})
    assert still["kl_mean"] == 0 and still["greedy_changed"] == 0
    assert still["entropy"][0] == still["entropy"][1]
    assert tool.main(["replay", str(out / "256"), "--variant", "small:eps=1e-3,n_epochs=1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines[1:]] == ["as", "small"]
    with pytest.raises(SystemExit, match="unknown setting 'gamma'"):
        tool.main(["replay", str(out / "256"), "--variant", "x:gamma=0.9"])
