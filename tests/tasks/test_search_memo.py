"""The kept search answers (``multicrane.tasks.search_memo``): a digest that changes with every
input of a search, one yard per memo, and rollout planners that play exactly the same episodes,
counters included, with the answers shared between their copies as without."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import multicrane
import policies
from multicrane.tasks.carrier import Carrier
from multicrane.tasks.reservation_arrays import ReservationArrays
from multicrane.tasks.search_memo import SearchMemo, remembered

SCALARS = (3, 120, 7, 145, -1, True, 40, 20000)  # comp, start, t, goal, zone, lift, slack, cap


def _inputs():
    state = SimpleNamespace(pickup=[[10, 11], [20], []],
                            status=np.array([0, 1, 3], dtype=np.int8),
                            filled=np.array([-1, -1, 4], dtype=np.int16))  # fmt: skip
    res = ReservationArrays()
    res.hold([50, 51], 2, 9, 1)
    return state, res, (0, 1), {60, 61}, SCALARS


def _changed(what: str):
    """The inputs with one of them changed."""
    state, res, rel, stops, scalars = _inputs()
    if what == "rows":
        res.hold([52], 2, 9, 1)
    elif what == "row time":
        res.rows[0, 2] = 10
    elif what == "status":
        state.status[1] = 2
    elif what == "filled":
        state.filled[2] = 5
    elif what == "stops":
        stops = {60}
    elif what == "rel":
        rel = (0, 2)
    elif what.startswith("scalar "):
        i = int(what.split()[1])
        scalars = scalars[:i] + (scalars[i] + 1,) + scalars[i + 1 :]
    return state, res, rel, stops, scalars


CHANGES = ["rows", "row time", "status", "filled", "stops", "rel"]
CHANGES += [f"scalar {i}" for i in range(len(SCALARS))]


@pytest.mark.parametrize("what", CHANGES)
def test_the_digest_changes_with_every_input(what):
    state, res, rel, stops, scalars = _inputs()
    memo = SearchMemo(state.pickup)
    same = memo.key(*_inputs())
    assert memo.key(state, res, rel, stops, scalars) == same
    assert memo.key(*_changed(what)) != same


def test_the_stop_poses_count_as_a_set():
    state, res, rel, _, scalars = _inputs()
    memo = SearchMemo(state.pickup)
    assert memo.key(state, res, rel, [61, 60], scalars) == memo.key(state, res, rel, {60, 61},
                                                                     scalars)  # fmt: skip


def test_another_yard_empties_the_memo_an_equal_one_keeps_it():
    state, *rest = _inputs()
    memo = SearchMemo(state.pickup)
    memo.put(memo.key(state, *rest), [1, 2], 5)
    copied = SimpleNamespace(**vars(state))
    copied.pickup = [list(p) for p in state.pickup]  # a copy of the site: the same yard
    assert memo.get(memo.key(copied, *rest)) == ([1, 2], 5)
    other = SimpleNamespace(**vars(state))
    other.pickup = [[12, 13], [20], []]
    memo.key(other, *rest)
    assert len(memo) == 0


def test_kept_paths_are_handed_out_as_fresh_lists_and_the_memo_starts_afresh_when_full():
    state, *rest = _inputs()
    memo = SearchMemo(state.pickup, capacity=2)
    key = memo.key(state, *rest)
    memo.put(key, [4, 5, 6], 9)
    path, expansions = memo.get(key)
    path.append(7)
    assert memo.get(key) == ([4, 5, 6], 9) and memo.hits == 2
    memo.put(b"x" * 16, None, 3)
    assert memo.get(b"x" * 16) == (None, 3)
    memo.put(b"y" * 16, None, 1)  # the third answer: the memo was full
    assert len(memo) == 1 and memo.get(key) is None


def test_remembered_asks_the_search_once_per_inputs():
    state, *rest = _inputs()
    asked = []

    def search():
        asked.append(1)
        return [7, 8], 11

    memo = SearchMemo(state.pickup)
    for _ in range(3):
        assert remembered(memo, search, state, *rest) == ([7, 8], 11)
    assert len(asked) == 1
    assert remembered(None, search, state, *rest) == ([7, 8], 11) and len(asked) == 2


def test_a_carrier_shares_one_memo_per_episode_and_none_on_sites_with_events():
    env = multicrane.parallel_env("hall-4c", n_cranes=4, decisions="task")
    env.reset(seed=0)
    carrier = env.unwrapped.mode.task_book().carrier
    assert carrier.memo is None
    memo = carrier.share_searches()
    assert memo is not None and carrier.share_searches() is memo
    env.reset(seed=1)
    assert carrier.memo is None
    eventful = multicrane.parallel_env("hall-4c", n_cranes=4, decisions="task", events="high")
    eventful.reset(seed=0)
    assert eventful.unwrapped.mode.task_book().carrier.share_searches() is None


def _episode(scenario, cranes, seed, policy):
    env = multicrane.parallel_env(scenario, n_cranes=cranes, decisions="task")
    obs, _ = env.reset(seed=seed)
    planner = policies.make(policy, env, seed=seed)
    while env.agents:
        obs, *_ = env.step(planner(obs))
    mode = env.unwrapped.mode
    return mode.trace, mode.decisions, dict(mode.carrier_stats()), mode.task_book().carrier.memo


PLANS = [("hall-4c", 4, 0, "prioritized:rank=chain,samples=4,guard=true,scorer=order-es21-s0"),
         ("precast-house", None, 1, "prioritized:samples=3,guard=true,scorer=order-es21-s0"),
         ("frame2-3c", 3, 0, "lookahead:rank=chain,candidates=2")]  # fmt: skip


@pytest.mark.parametrize("scenario, cranes, seed, policy", PLANS)
def test_rollout_planners_play_the_same_episodes_with_kept_answers(
    scenario, cranes, seed, policy, monkeypatch
):
    *shared, memo = _episode(scenario, cranes, seed, policy)
    assert memo is not None and memo.hits > 0  # the copies asked searches asked before
    monkeypatch.setattr(Carrier, "share_searches", lambda self: None)
    *alone, no_memo = _episode(scenario, cranes, seed, policy)
    assert no_memo is None
    assert shared == alone
