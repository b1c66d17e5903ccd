"""``render_mode="rgb_array"``: the isometric picture of a site (``multicrane.render.image``)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_masked_actions

import multicrane
from multicrane.envs.paper_env import PaperAssemblyEnv
from multicrane.render.image import (
    CLOSED,
    CRANE_DOWN,
    CRANE_IDLE,
    CRANE_WORKING,
    GHOST,
    GROUND,
    OBSTACLE,
    SHADES,
    SiteImage,
)


def _played(name: str, steps: int, seed: int = 0, **options):
    env = multicrane.parallel_env(name, render_mode="rgb_array", **options)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        if not env.agents:
            break
        obs, *_ = env.step(random_masked_actions(obs, rng))
    return env


def _top(rgb) -> np.ndarray:
    return np.round(np.array(rgb) * SHADES[0]).astype(np.uint8)


def _has_color(frame: np.ndarray, rgb) -> bool:
    return bool((frame.reshape(-1, 3) == _top(rgb)).all(axis=1).any())


@pytest.mark.parametrize("name", ["e1s1", "hall-4c", "frame2-3c", "precast-house"])
def test_a_frame_is_an_rgb_image_of_fixed_shape(name):
    env = _played(name, 30)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.shape == SiteImage(env.sim).shape + (3,)
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 4  # not a blank picture


def test_same_episode_same_frames_and_moves_change_them():
    a, b = _played("hall-4c", 40), _played("hall-4c", 40)
    assert np.array_equal(a.render(), b.render())
    c = _played("hall-4c", 60)
    assert not np.array_equal(a.render(), c.render())


def test_components_take_their_state_colours():
    env = _played("hall-4c", 0)
    frame = env.render()
    initial = env.sim.scenario.components[0]
    from multicrane.core.kinds import kind_spec

    assert _has_color(frame, kind_spec(int(initial.kind)).colors[0][:3])  # initial


def test_closed_zones_and_broken_cranes_are_drawn():
    # A high level of site events closes zones and breaks cranes in most episodes.
    closed_on_ground = (0.6 * _top(CLOSED) + 0.4 * _top(GROUND)).astype(np.uint8)
    seen = set()
    for seed in range(20):
        env = _played("towers-3c", 0, seed=seed, events="high")
        rng = np.random.default_rng(seed)
        obs = env.reset(seed=seed)[0]
        while env.agents and len(seen) < 2:
            obs, *_ = env.step(random_masked_actions(obs, rng))
            frame = env.render()
            if any(not env.sim.crane_up(k) for k in range(env.sim.n_cranes)):
                assert _has_color(frame, CRANE_DOWN)
                seen.add("down")
            if env.sim.closed.any():
                assert (frame.reshape(-1, 3) == closed_on_ground).all(axis=1).any()
                seen.add("closed")
        if len(seen) == 2:
            return
    pytest.fail(f"20 episodes of towers-3c at events='high' showed only {seen}")


def test_masts_show_what_each_crane_does():
    env = _played("towers-3c", 0)
    frame = env.render()
    assert env.sim.scenario.crane_specs, "towers-3c has crane reach"
    assert _has_color(frame, CRANE_IDLE) or _has_color(frame, CRANE_WORKING)


def test_paper_env_renders_rgb_array():
    env = PaperAssemblyEnv("E2S2", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.shape[2] == 3
    env.step(0)
    assert env.render().shape == frame.shape


def test_unknown_render_mode_is_refused_by_name():
    with pytest.raises(ValueError, match="'video'"):
        multicrane.parallel_env("e2s2", render_mode="video")


def test_free_targets_are_faint_ghosts_never_dark_blots():
    # A ghost is a quarter of its dark grey over what is behind it: nothing in the picture is
    # darker (summed over the channels) than the darkest face of an obstacle seen through
    # one.
    frame = _played("hall-4c", 0).render()
    darkest = 0.75 * np.array(OBSTACLE) * min(SHADES) + 0.25 * np.array(GHOST) * min(SHADES)
    assert frame.astype(int).sum(axis=2).min() >= int(darkest.sum()) - 3
