"""``tools/departures.py``: the planner's proposal read back from the hint column, and the
report of a fit on one file measured on another."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from conftest import load_tool, one_torch_thread  # noqa: F401 (fixture)

import policies
from multicrane.training import TrainConfig
from multicrane.training.imitation import demonstrate, save
from multicrane.training.set_training import make_set_vec_env

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _demos(tmp_path, teacher: str, seed: int, hint: bool = True) -> str:
    cfg = TrainConfig("e3s3", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                      policy="set", planner_hint=hint, reward="makespan", shaping=0.0)  # fmt: skip
    venv = make_set_vec_env(cfg, 2, 0.99, workers=1)
    venv.seed(seed)
    demos = demonstrate(venv, policies.factory(teacher), 3, gamma=0.99)
    path = str(tmp_path / f"{teacher}-{seed}-{hint}.npz")
    save(demos, path, {"limits": venv.limits.to_dict()})
    venv.close()
    return path


def test_the_prioritized_planner_never_departs_from_its_own_hint(tmp_path):
    tool = load_tool("departures")
    demos, limits = tool.read(_demos(tmp_path, "prioritized", 0))
    rows = demos.decisions
    assert rows.sum() > 5
    proposed = tool.proposed_actions(demos.observations, limits)
    assert np.array_equal(proposed[rows], demos.actions[rows])
    # The look-ahead departs from it (and an earlier crane's departure can claim the task
    # proposed to a later crane, so a proposal need not be allowed by the exclusive mask).
    ahead, _ = tool.read(_demos(tmp_path, "lookahead:candidates=4", 0))
    proposed = tool.proposed_actions(ahead.observations, limits)
    assert (proposed[ahead.decisions] != ahead.actions[ahead.decisions]).any()


def test_the_report_fits_one_file_and_measures_both(tmp_path, monkeypatch, capsys):
    tool = load_tool("departures")
    train, heldout = (_demos(tmp_path, "lookahead:candidates=4", s) for s in (0, 1))
    monkeypatch.setattr(sys, "argv", ["departures", train, heldout, "--epochs", "2"])
    tool.main()
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "share 1.0 of the training rows, 2 epochs, seed 0"
    assert [line.split()[0] for line in lines[2:]] == ["training", "held-out"]
    for line in lines[2:]:
        decided, agreement, departures = line.split()[1:4]
        assert int(decided) > 0 and 0 <= float(agreement) <= 1 and int(departures) >= 0
    plain = _demos(tmp_path, "prioritized", 2, hint=False)
    with pytest.raises(SystemExit, match="without the planner's hint"):
        tool.read(plain)
