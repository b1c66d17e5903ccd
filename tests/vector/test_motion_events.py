"""The vector motion env with site events equals the one-site env, copy by copy (issue 31).

Late deliveries, crane breakdowns and closed zones (``multicrane.sim.events``): the events
levels on small and large sites, every crane count of a scenario, an ``EventSpec`` dense
enough that every kind of site event happens in short episodes, a scenario's own
``[events]`` table, and hypothesis drawing scenarios, seeds, levels and actions. Every step's
observations (events block included), masks, rewards, flags, event counts, site event counts
and each copy's generator equal those of ``MultiCraneEnv`` copies reset with the same seeds,
autoresets included (``play_both`` of the motion differential tests). The runs assert that
every kind of site event and autoresets happened. Large runs are behind ``-m fuzz``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_motion_differential import DRAWN, SCENARIOS, play_both

from multicrane.core.codes import SiteEventType
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.scenario.loader import load_scenario
from multicrane.sim.events import LEVELS, EventSpec, FixedClosure
from multicrane.vector.motion_vector_env import MotionVectorEnv

# Every kind of site event within a few dozen steps: half the components late, breakdowns
# and random closures every 20 steps on average, and a fixed closure from the start.
DENSE = EventSpec(
    late_fraction=0.5, delay=(1, 30), breakdown_rate=0.05, breakdown_duration=(2, 8),
    closures=(FixedClosure(((0, 0, 1), (2, 2, 3)), 0, 15),), closure_rate=0.05,
    closure_size=(1, 3), closure_duration=(2, 10),
)  # fmt: skip
EVENTS_TABLE = """
[events]
late_fraction = 0.5
delay = [1, 20]
breakdown_rate = 0.05
breakdown_duration = [2, 6]
closure_rate = 0.06
closure_size = [1, 3]
closure_duration = [2, 8]

[[events.closures]]
min = [0, 0, 1]
max = [3, 3, 2]
start = 0
end = 12
"""
WITH_TABLE = [s for s in SCENARIOS if load_scenario(s).events is not None]


def _play(scenario, n, seeds, steps, **options) -> tuple[int, np.ndarray]:
    """``play_both`` with site events: (episodes ended, site events seen per type)."""
    seen = np.zeros(len(SiteEventType), dtype=np.int64)
    return play_both(scenario, n, seeds, steps, seen=seen, **options), seen


@pytest.mark.parametrize("level", LEVELS)
@pytest.mark.parametrize(("scenario", "n"), [("e1s1", 1), ("e2s3", 2), ("hall-4c", 4)])
def test_every_level(scenario, n, level):
    """The preset levels, through two episodes of each copy (truncated at 40 steps)."""
    ended, _ = _play(scenario, n, [n, n + 5], steps=45, events=level, max_steps=20)
    assert ended >= 4


def test_every_crane_count_with_dense_events():
    """Every crane count e2s3 accepts, every kind of site event, autoresets."""
    for n in (1, 2, 3, 4):
        ended, seen = _play("e2s3", n, [11 * n, 11 * n + 1], steps=90, events=DENSE,
                            max_steps=40)  # fmt: skip
        assert ended >= 2 and seen.all(), (n, seen)


@pytest.mark.parametrize(("scenario", "n"), DRAWN)
def test_every_kind_of_event_on_drawn_sites(scenario, n):
    """Deliveries, breakdowns and returns, closures and openings all happen and agree."""
    ended, seen = _play(scenario, n, [n, 3 * n + 1], steps=80, events=DENSE, max_steps=35,
                        greedy=0.9)  # fmt: skip
    assert ended >= 2 and seen.all(), seen


def test_a_scenarios_events_table(tmp_path):
    """``events=None`` takes the scenario's ``[events]`` table, as the one-site env does
    (shipped scenarios with a table, and a copy of e2s3 with one)."""
    path = tmp_path / "e2s3-events.toml"
    path.write_text(Path("scenarios/e2s3.toml").read_text() + EVENTS_TABLE)
    assert load_scenario(path).events is not None
    ended, seen = _play(str(path), 2, [4, 9], steps=70, max_steps=30)
    assert ended >= 2 and seen.all(), seen
    for scenario in WITH_TABLE:
        _play(scenario, None, [1, 2], steps=30)


def test_site_event_counts_and_events_block():
    """The infos carry ``site_event_counts`` [B, len(SiteEventType)] only with events on;
    the observation grows by the events block; a bad level is refused as by the one-site env."""
    plain = MotionVectorEnv(2, "e2s3", n_cranes=2)
    _, infos = plain.reset(seed=0)
    assert "site_event_counts" not in infos
    env = MotionVectorEnv(2, "e2s3", n_cranes=2, events="none")
    obs, infos = env.reset(seed=0)
    assert infos["site_event_counts"].shape == (2, len(SiteEventType))
    ref = MultiCraneEnv("e2s3", n_cranes=2, obs_format="flat", events="none")
    assert obs.shape[2] == ref.observation_layout.size > plain.buffers.obs.shape[2]
    parts = ref.observation_layout.split(obs[0, 0])
    assert parts["delivered"].all() and parts["available"].all() and not parts["closed"].any()
    with pytest.raises(ValueError, match="events level must be one of"):
        MotionVectorEnv(1, "e2s3", events="medium")


def test_schedule_tables_grow():
    """A copy whose schedule has more outages or closures than the tables held gets them
    all: the tables grow, and the copies stay equal to the one-site env."""
    spec = EventSpec(breakdown_rate=0.3, breakdown_duration=(1, 2), closure_rate=0.3,
                     closure_duration=(1, 2))  # fmt: skip
    ended, seen = _play("e1s1", 1, [5, 6], steps=60, events=spec, max_steps=25)
    assert ended >= 4 and seen[SiteEventType.CRANE_UP] > 10


@settings(max_examples=8, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(
    case=st.sampled_from(DRAWN),
    seed=st.integers(0, 2**32 - 1),
    events=st.sampled_from(["none", "low", "high", DENSE]),
    greedy=st.sampled_from([0.0, 0.7, 0.95]),
    wild=st.sampled_from([0.0, 0.05, 0.3]),
    reward_mode=st.sampled_from(["team", "split"]),
)
def test_random_runs_with_events_equal(case, seed, events, greedy, wild, reward_mode):
    scenario, n = case
    play_both(scenario, n, [seed, seed + 1], steps=30, greedy=greedy, wild=wild,
              events=events, reward_mode=reward_mode, max_steps=20)  # fmt: skip


@pytest.mark.fuzz
@settings(max_examples=80, deadline=None)  # about 4 minutes of CI's fuzz step
@given(
    case=st.sampled_from(DRAWN),
    seed=st.integers(0, 2**32 - 1),
    events=st.sampled_from(["none", "low", "high", DENSE]),
    greedy=st.floats(0.0, 1.0),
    wild=st.sampled_from([0.0, 0.05, 0.3]),
    reward=st.sampled_from(["paper", "makespan"]),
    max_steps=st.sampled_from([None, 60, 200]),
)
def test_long_random_runs_with_events_equal(case, seed, events, greedy, wild, reward,
                                            max_steps):  # fmt: skip
    scenario, n = case
    play_both(scenario, n, [seed, seed + 1, seed + 2], steps=400, greedy=greedy, wild=wild,
              events=events, reward=reward, max_steps=max_steps)  # fmt: skip
