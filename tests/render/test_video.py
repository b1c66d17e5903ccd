"""Episode videos: ``multicrane plan --video`` (``multicrane.render.video``) and Gymnasium's
``RecordVideo`` on the paper env and on hall-4c (through ``multicrane/Joint-v0``), each file
read back. Needs the ``video`` extra (skipped without it, except the one-line refusal)."""

from __future__ import annotations

import builtins

import gymnasium as gym
import numpy as np
import pytest

import multicrane
from multicrane.cli import main
from multicrane.envs.paper_env import paper_env_id
from multicrane.episodes.rollout import run_episode
from multicrane.render.image import SiteImage
from multicrane.render.video import EpisodeVideo


def _frames_of(path) -> tuple[int, tuple[int, int]]:
    """(frames, (width, height)) of a video file, decoded by ffmpeg."""
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    reader = imageio_ffmpeg.read_frames(str(path))
    size = next(reader)["size"]
    reader.close()
    return imageio_ffmpeg.count_frames_and_secs(str(path))[0], size


def _first_frame(path) -> np.ndarray:
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    reader = imageio_ffmpeg.read_frames(str(path))
    width, height = next(reader)["size"]
    frame = np.frombuffer(next(reader), dtype=np.uint8).reshape(height, width, 3)
    reader.close()
    return frame


def test_an_episode_video_has_a_frame_per_reset_and_step(tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    env = multicrane.parallel_env("hall-4c", max_steps=25)
    policy = lambda obs: {a: env.wait_action for a in obs}  # noqa: E731
    with EpisodeVideo(tmp_path / "ep.mp4", fps=8) as video:
        result = run_episode(env, policy, 0, on_reset=video.on_reset, on_step=video.on_step)
    assert result["steps"] == 25 and video.frames == 26
    env.reset(seed=0)
    picture = SiteImage(env.sim).draw(env.sim)
    assert _frames_of(tmp_path / "ep.mp4") == (26, (picture.shape[1], picture.shape[0]))
    # H.264 is lossy, but the first frame is the reset's picture, unscaled.
    error = np.abs(_first_frame(tmp_path / "ep.mp4").astype(int) - picture).mean()
    assert error < 3, error


def test_plan_video_writes_the_first_episode(tmp_path, capsys):
    pytest.importorskip("imageio_ffmpeg")
    path = tmp_path / "ep.mp4"
    assert main(["plan", "e2s2", "--policy", "prioritized", "--video", str(path)]) == 0
    out = capsys.readouterr().out
    env = multicrane.parallel_env("e2s2")
    import policies

    steps = run_episode(env, policies.make("prioritized", env, seed=0), 0)["steps"]
    assert f"video: {path} ({steps + 1} frames)" in out
    assert _frames_of(path)[0] == steps + 1


def test_plan_video_as_a_gif_in_paper_mode(tmp_path, capsys):
    Image = pytest.importorskip("PIL.Image")
    path = tmp_path / "ep.gif"
    assert main(["plan", "E1S1", "--paper", "--policy", "greedy", "--video", str(path),
                 "--fps", "5"]) == 0  # fmt: skip
    frames = int(capsys.readouterr().out.split("(")[-1].split()[0])
    with Image.open(path) as gif:
        # Pillow merges identical frames into a longer one: the time adds up.
        durations = []
        for i in range(gif.n_frames):
            gif.seek(i)
            durations.append(gif.info["duration"])
    assert sum(durations) == frames * 200


def test_plan_video_without_the_extra_names_it_in_one_line(tmp_path, capsys, monkeypatch):
    real = builtins.__import__

    def no_video(name, *args, **kwargs):
        if name.split(".")[0] in ("imageio_ffmpeg", "PIL", "moviepy"):
            raise ImportError(f"No module named {name!r}")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_video)
    assert main(["plan", "e2s2", "--video", str(tmp_path / "ep.mp4")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "multicrane plan needs the 'video' extra: pip install 'multicrane[video]'"
    assert not (tmp_path / "ep.mp4").exists()


def test_plan_video_needs_one_policy(tmp_path, capsys):
    assert main(["plan", "e2s2", "--policy", "greedy", "random",
                 "--video", str(tmp_path / "ep.mp4")]) == 2  # fmt: skip
    assert "--video needs one policy" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("env_id", "options"),
    [
        (paper_env_id("E2S2"), {}),
        ("multicrane/Joint-v0", {"scenario": "hall-4c", "max_steps": 30}),
    ],
)
def test_gymnasium_record_video_records_an_episode(env_id, options, tmp_path):
    pytest.importorskip("moviepy")
    env = gym.make(env_id, render_mode="rgb_array", **options)
    env = gym.wrappers.RecordVideo(env, str(tmp_path / "videos"), name_prefix="ep")
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    steps, done = 0, False
    while not done:
        masks = np.asarray(env.unwrapped.action_masks(), dtype=bool)
        if masks.ndim == 1:
            action = int(rng.choice(np.flatnonzero(masks)))
        else:
            action = [int(rng.choice(np.flatnonzero(m))) for m in masks]
        _, _, terminated, truncated, _ = env.step(action)
        steps, done = steps + 1, terminated or truncated
    env.close()
    (video,) = (tmp_path / "videos").glob("ep-episode-0.mp4")
    assert _frames_of(video)[0] == steps + 1
