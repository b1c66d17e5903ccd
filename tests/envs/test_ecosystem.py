"""docs/ecosystem.md's recipes: every file under docs/recipes/ is shown in the page and runs.

Each recipe runs in this process (``runpy``), skipped when its library is not installed;
together they take about 15 s (the training ones run a few hundred steps only).
"""

from __future__ import annotations

import runpy
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RECIPES = sorted((ROOT / "docs" / "recipes").glob("*.py"))
NEEDS = {
    "benchmarl_mappo": "benchmarl",  # its own venv: tools/test_benchmarl.sh
    "pettingzoo_checks": "pettingzoo",
    "rllib_ppo": "multicrane.integrations.rllib",
    "sb3_maskable_gymnasium": "sb3_contrib",
    "sb3_supersuit": "supersuit",
    "tianshou_collect": "tianshou",
    "tianshou_dqn_train": "tianshou",
    "torchrl_mappo_train": "torchrl",
    "torchrl_wrapper": "torchrl",
}


def test_every_recipe_is_in_the_page_and_has_its_library_named():
    page = (ROOT / "docs" / "ecosystem.md").read_text()
    assert {r.stem for r in RECIPES} == set(NEEDS)
    for r in RECIPES:
        assert f"docs/recipes/{r.name}" in page, f"docs/ecosystem.md does not show {r.name}"


# Builds and trains an RLlib algorithm (about 25 s): behind the ``long`` marker (-m long).
LONG = {"rllib_ppo"}


@pytest.mark.parametrize(
    "recipe",
    [pytest.param(r, marks=pytest.mark.long) if r.stem in LONG else r for r in RECIPES],
    ids=lambda p: p.stem,
)
def test_recipe_runs(recipe, monkeypatch, capsys):
    pytest.importorskip(NEEDS[recipe.stem], exc_type=ImportError)
    monkeypatch.chdir(ROOT)
    runpy.run_path(str(recipe), run_name="__main__")
