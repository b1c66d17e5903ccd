"""The task level's compiler: a scenario's tasks, shapes, goal poses and observation tables.

``compile_task_site(env)`` reads a ``MultiCraneEnv(decisions="task")`` (its task book, carrier
and task observer) into one ``TaskSite``, the named tuple the task kernels read beside the
motion mode's ``MotionSite`` (``multicrane.vector.motion_site``: the grid, the components, the
start rule, the reward). A component's *shape* is the offsets of its lifted pose's cells from
the first (``multicrane.tasks.reservations.shape_of``): the pick-up pose keeps its own
target's box (``multicrane.sim.geometry.lifted_pose``), so each component has one shape for
ever, and the goal poses, the reach fields and the distance oracles of the searches are kept
per shape.

Supported: the task decision level without site events and without the site planes
(``task_site_planes``), with or without crane reach, both rewards and reward modes.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.envs.task_observation import TASK_FEATURES
from multicrane.sim import geometry
from multicrane.sim.shortest_paths import fits_everywhere
from multicrane.vector.start_arrays import padded


class TaskSite(NamedTuple):
    """What the task kernels read about a scenario and the env's task options."""

    # -- tasks (``multicrane.tasks.task_list``) ------------------------------------------------
    task_comp: np.ndarray  # (P,) int64: each task's component
    task_target: np.ndarray  # (P,) int64: its target
    task_of: np.ndarray  # (C, C) int64: the task of (component, target), -1 none
    # -- shapes and goal poses (``multicrane.tasks.goal_poses``) -------------------------------
    shape_of: np.ndarray  # (C,) int64: each component's shape
    shape_rel: np.ndarray  # (S, L) int64: a shape's cell offsets from its first cell
    shape_len: np.ndarray  # (S,) int64: its cells
    goal: np.ndarray  # (S, C) int64: where the shape covers target t exactly, -1 nowhere
    reach_fit: np.ndarray  # (S, Z, P) bool: the shape lies wholly in zone z there (Z = 1
    #                        without reach: everywhere)
    coords: np.ndarray  # (3 P,) int32: a position's grid x, y, z (``ShapeCache.coords``)
    # -- the carrier and the book ----------------------------------------------------------
    slack: int
    max_expansions: int
    patience: int
    # -- the task observation (``multicrane.envs.task_observation``) ----------------------------
    obs_size: int
    cell_xyz: np.ndarray  # (P, 3) float32: a cell's site coordinates / the site size
    beam: np.ndarray  # (C,) bool
    target_nodes: np.ndarray  # (C, 6) float32: each target's node 1 and node 2
    reach_row: np.ndarray  # (N, 3) float32: each crane's base x, base y and radius
    D: float  # X + Y + H: path lengths are divided by it
    T_norm: float  # D + assembly steps + 1: times are divided by it
    cycle_limit: int  # ``max_cycles`` (decision rounds), 0 for none


def _check_options(env: MultiCraneEnv) -> None:
    if env.mode.task_level is not True:
        raise ValueError("the task vector env needs decisions='task'")
    if env.sim.events is not None:
        raise ValueError(
            f"{env.scenario.name}: site events are not modelled at the task level of the "
            "vector env (events='none' turns a scenario's [events] table off)"
        )
    if env.mode.observer.planes is not None:
        raise ValueError("task_site_planes=True is not modelled in the task vector env")


def compile_task_site(env: MultiCraneEnv) -> TaskSite:
    """The task arrays of ``env`` (ValueError for what the kernels do not model)."""
    _check_options(env)
    book, observer = env.mode.task_book(), env.mode.observer
    sim, carrier = env.sim, book.carrier
    site = sim.site
    C = site.n_components
    tasks = book.tasks
    task_of = np.full((C, C), -1, dtype=np.int64)
    task_of[tasks.comp, tasks.target] = np.arange(len(tasks))
    rels = [lifted_shape(env, c) for c in range(C)]
    shapes = sorted(set(rels))
    shape_of = np.array([shapes.index(r) for r in rels], dtype=np.int64)
    goal = np.array(
        [[-1 if (g := carrier.goals[rel, t]) is None else g for t in range(C)] for rel in shapes],
        dtype=np.int64,
    ).reshape(len(shapes), C)
    zones = [site.reach[k] for k in range(sim.n_cranes)] if site.reach is not None else None
    everywhere = np.ones(site.size, dtype=bool)
    reach_fit = np.stack([
        np.stack([fits_everywhere(z, rel) for z in zones]) if zones else everywhere[None]
        for rel in shapes
    ])  # fmt: skip
    return TaskSite(
        task_comp=tasks.comp.copy(),
        task_target=tasks.target.copy(),
        task_of=task_of,
        shape_of=shape_of,
        shape_rel=padded([list(r) for r in shapes]),
        shape_len=np.array([len(r) for r in shapes], dtype=np.int64),
        goal=goal,
        reach_fit=reach_fit,
        coords=carrier.shapes.coords,
        slack=carrier.slack,
        max_expansions=carrier.max_expansions,
        patience=book.patience,
        **observer.site_tables(),
        cycle_limit=env.max_cycles or 0,
    )


def lifted_shape(env: MultiCraneEnv, comp: int) -> tuple[int, ...]:
    """The offsets of ``comp``'s lifted pose's cells from its first: the shape it has from
    its pick-up on (the lifted pose keeps its own target's box, wherever it lay)."""
    scenario, site = env.scenario, env.sim.site
    spec = scenario.components[comp]
    pose = geometry.lifted_pose(
        spec.kind, spec.length, spec.target, spec.target, scenario.beam_lift_z
    )
    cells = geometry.pose_cells(*pose)
    x0, y0, z0 = cells[0]
    base = site.lin(x0, y0, z0)
    return tuple(site.lin(x, y, z) - base for x, y, z in cells)


TASK_WIDTH = len(TASK_FEATURES)
