"""The set policy's environment copies in worker processes, when there are cores to use.

In task mode the environment's step (the carrier's space-time searches, the observation)
is most of a training run's CPU time (``multicrane marl-bench --throughput``), so on a
machine with free cores the copies pay to run in parallel. ``WorkerSetVecEnv`` splits the
``n_envs`` copies of a ``SetVecEnv`` over ``workers`` processes (copy ``i`` to worker
``i * workers // n_envs``, contiguous blocks), each running its block as a ``SetVecEnv``
with the seeds the copies would get in one process, and concatenates their rows. Without a
curriculum the rows, rewards and episodes are the same as one ``SetVecEnv``'s, whatever the
number of workers (tested); with one, each worker's curriculum moves on by its own copies'
episodes. Checkpoints gather every worker's state.
"""

from __future__ import annotations

import multiprocessing as mp
import pickle
from collections.abc import Callable, Sequence

import numpy as np
from stable_baselines3.common.vec_env import VecEnv

from multicrane.training.seeding import copy_seeds


def _serve(conn, build: bytes) -> None:
    """A worker's loop: build its ``SetVecEnv`` and answer commands until ``close``."""
    venv = pickle.loads(build)()
    while True:
        cmd, arg = conn.recv()
        if cmd == "step":
            venv.step_async(arg)
            conn.send((*venv.step_wait(), venv.action_masks()))
        elif cmd == "reset":
            conn.send((venv.reset(), venv.action_masks()))
        elif cmd == "seed":
            venv._copy_seeds = list(arg)
            conn.send(None)
        elif cmd == "get_state":
            conn.send(venv.get_state())
        elif cmd == "set_state":
            venv.set_state(arg)
            conn.send(venv.action_masks())
        elif cmd == "call":
            name, args, kwargs = arg
            conn.send(getattr(venv, name)(*args, **kwargs))
        elif cmd == "close":
            venv.close()
            conn.send(None)
            return


class WorkerSetVecEnv(VecEnv):
    """``make_block(n)`` (a picklable callable returning a ``SetVecEnv`` of ``n`` copies) run
    in ``workers`` processes; see the module doc."""

    def __init__(self, make_block: Callable[[int], VecEnv], n_envs: int, workers: int):
        if not 1 <= workers <= n_envs:
            raise ValueError(f"workers={workers}: must be between 1 and n_envs={n_envs}")
        self.n_copies = n_envs
        self.blocks = [
            [i for i in range(n_envs) if i * workers // n_envs == w] for w in range(workers)
        ]
        probe = make_block(1)
        self.limits = probe.limits
        self.n_agents = probe.n_agents  # rows per copy, as in SetVecEnv
        super().__init__(n_envs * probe.n_agents, probe.observation_space, probe.action_space)
        probe.close()
        ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
        self.conns, self.procs = [], []
        import cloudpickle

        for block in self.blocks:
            parent, child = ctx.Pipe()
            build = cloudpickle.dumps(_Block(make_block, len(block)))
            proc = ctx.Process(target=_serve, args=(child, build), daemon=True)
            proc.start()
            child.close()
            self.conns.append(parent)
            self.procs.append(proc)
        self._masks = np.ones((self.num_envs, self.action_space.n), dtype=bool)
        self.sites = None

    def _all(self, cmd: str, args: Sequence | None = None) -> list:
        for i, conn in enumerate(self.conns):
            conn.send((cmd, None if args is None else args[i]))
        return [conn.recv() for conn in self.conns]

    def seed(self, seed: int | None = None):
        seeds = copy_seeds(seed, self.n_copies)
        self._all("seed", [[seeds[i] for i in block] for block in self.blocks])
        return seeds

    def reset(self):
        out = self._all("reset")
        self._masks = np.concatenate([m for _, m in out])
        return np.concatenate([o for o, _ in out])

    def step_async(self, actions: np.ndarray) -> None:
        flat, at = np.asarray(actions).reshape(-1), 0
        for conn, block in zip(self.conns, self.blocks, strict=True):
            n = len(block) * self.n_agents
            conn.send(("step", flat[at : at + n]))
            at += n

    def step_wait(self):
        out = [conn.recv() for conn in self.conns]
        obs, rewards, dones, infos, masks = zip(*out, strict=True)
        self._masks = np.concatenate(masks)
        flat_infos = [info for block in infos for info in block]
        return np.concatenate(obs), np.concatenate(rewards), np.concatenate(dones), flat_infos

    def action_masks(self) -> np.ndarray:
        return self._masks.copy()

    def get_state(self) -> bytes:
        return pickle.dumps(self._all("get_state"))

    def set_state(self, state: bytes) -> None:
        masks = self._all("set_state", pickle.loads(state))
        self._masks = np.concatenate(masks)

    def _rows(self, indices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        return [indices] if isinstance(indices, int) else list(indices)

    def _gather(self, name: str, *args, **kwargs) -> list:
        """``name(*args, **kwargs)`` of every worker's ``SetVecEnv``, rows concatenated."""
        out = self._all("call", [(name, args, kwargs)] * len(self.conns))
        return [x for block in out for x in block]

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs):
        if method_name == "action_masks":
            return list(self._masks[self._rows(indices)])
        rows = self._gather("env_method", method_name, *method_args, **method_kwargs)
        return [rows[r] for r in self._rows(indices)]

    def get_attr(self, attr_name: str, indices=None):
        if attr_name == "action_masks":
            return [self.action_masks for _ in self._rows(indices)]
        if not getattr(self, "conns", None):  # VecEnv's own constructor asks for render_mode
            return [None for _ in self._rows(indices)]
        rows = self._gather("get_attr", attr_name)
        return [rows[r] for r in self._rows(indices)]

    def set_attr(self, attr_name: str, value, indices=None) -> None:
        raise NotImplementedError(f"set_attr({attr_name!r}) across worker processes")

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False] * self.num_envs

    def close(self) -> None:
        if self.conns:
            self._all("close")
            for proc in self.procs:
                proc.join(timeout=5)
            self.conns, self.procs = [], []


class _Block:
    """A picklable ``make_block`` bound to its number of copies."""

    def __init__(self, make_block: Callable[[int], VecEnv], n: int):
        self.make_block, self.n = make_block, n

    def __call__(self) -> VecEnv:
        return self.make_block(self.n)
