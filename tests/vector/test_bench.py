"""``multicrane bench --vector`` and its measurements (``multicrane.vector.bench``)."""

from __future__ import annotations

import numpy as np
import pytest

from multicrane.cli import main
from multicrane.vector import bench
from multicrane.vector.pcg64 import state_of


def test_the_sampler_draws_every_move_uniformly():
    rng = state_of(np.random.default_rng(0))[None].copy()
    moves = np.zeros(60_000, dtype=np.int64)
    bench.sample_moves(rng, moves)
    counts = np.bincount(moves, minlength=7)
    assert counts[6] == 0 and (abs(counts[:6] - 10_000) < 400).all()


def test_measurements():
    assert bench.steps_per_second("E1S1", 64, seconds=0.05) > 0
    per_copy = bench.bytes_per_copy("E1S1", 256)
    assert 5_000 < per_copy <= 64 * 1024  # issue 31: at most 64 KB per copy


@pytest.mark.long
def test_a_second_process_starts_from_the_cache():
    first, second = bench.start_seconds("E1S1")
    assert second < first


def fake_measurements(monkeypatch) -> None:
    """Stand-ins for the bench's measurements: 1,000 paper and 10 motion steps per second a
    copy (20 with uint8 observations), 30 s to start with an empty numba cache and 1.5 s with
    it, 200,000 bytes a copy (100,000 with uint8 observations); task rounds of 0.5 ms in the
    one-site env and 0.1 ms a call in the vector env, 300,000 bytes a copy."""
    from multicrane.cli import bench as bench_command

    monkeypatch.setattr(bench, "steps_per_second", lambda config, b: 1000.0 * b)
    monkeypatch.setattr(bench, "start_seconds",
                        lambda config, cranes=None, task=False: (30.0, 1.5))  # fmt: skip
    monkeypatch.setattr(bench_command, "task_round_seconds",
                        lambda scenario, n, rounds, policy: np.full(4, 5e-4))  # fmt: skip
    monkeypatch.setattr(bench, "task_round_seconds",
                        lambda scenario, n, rounds, policy, b=1: np.full(4, 1e-4))  # fmt: skip
    monkeypatch.setattr(bench, "task_bytes_per_copy", lambda scenario, n, b: 3e5)
    monkeypatch.setattr(bench, "motion_steps_per_second",
                        lambda scenario, cranes, b, events=None, obs_dtype=np.float32:
                        (20.0 if obs_dtype == np.uint8 else 10.0) * b)  # fmt: skip
    monkeypatch.setattr(bench, "motion_bytes_per_copy",
                        lambda scenario, cranes, b, obs_dtype=np.float32:
                        1e5 if obs_dtype == np.uint8 else 2e5)  # fmt: skip


def test_the_command_prints_both_envs(monkeypatch, capsys):
    fake_measurements(monkeypatch)
    assert main(["bench", "--vector", "--paper", "E2S2", "--steps", "50"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == ["config", "env", "copies", "steps/s", "bytes/copy"]
    assert out[1].split()[:3] == ["E2S2", "one-site", "1"]
    assert [line.split()[2:4] for line in out[2:6]] == [
        ["1", "1,000"], ["64", "64,000"], ["1024", "1,024,000"], ["4096", "4,096,000"]
    ]
    assert "30.0 s with an empty numba cache" in out[6] and "1.50 s with the cache" in out[6]
    motion = [line.split() for line in out[8:17]]  # after the motion header: hall-4c rows
    assert motion[0][:3] == ["hall-4c", "one-site", "1"]
    assert [row[1:5] for row in motion[1:]] == [
        [kind, str(b), f"{rate * b:,}", size]
        for b in (1, 64, 1024, 4096)
        for kind, rate, size in (("vector", 10, "200,000"), ("vector-u8", 20, "100,000"))
    ]
    task = [line.split() for line in out[19:27]]  # after the task header: hall-4c rows
    assert out[18].split() == ["scenario", "env", "copies", "policy", "rounds/s", "bytes/copy"]
    for policy, rows in (("prioritized", task[:4]), ("random", task[4:])):
        assert rows[0] == ["hall-4c", "one-site", "1", policy, "2,000"]
        assert [row[2:] for row in rows[1:]] == [
            [str(b), policy, f"{10_000 * b:,}", "300,000"] for b in (1, 64, 1024)
        ]
    assert "task env, first round" in out[27] and "1.50 s with the cache" in out[27]


def test_events_reach_both_motion_envs_and_need_vector(monkeypatch, capsys):
    fake_measurements(monkeypatch)
    levels = []
    monkeypatch.setattr(bench, "motion_steps_per_second",
                        lambda scenario, cranes, b, events=None, obs_dtype=None:
                        levels.append(events) or 1.0)  # fmt: skip
    from multicrane.cli import bench as bench_command

    one_site = []
    monkeypatch.setattr(bench_command, "joint_steps_per_second",
                        lambda *a, events=None, **k: one_site.append(events) or 1.0)
    assert main(["bench", "--vector", "--paper", "E2S2", "--steps", "50", "--events", "high"]) == 0
    assert "site events: high" in capsys.readouterr().out
    assert set(levels) == {"high"} and set(one_site) == {"high"}
    assert main(["bench", "--events", "high"]) == 2
    assert "--events goes with --vector" in capsys.readouterr().err


def test_the_vector_motion_env_is_timed_with_events():
    assert bench.motion_steps_per_second("e2s3", 2, 4, seconds=0.05, events="high") > 0
