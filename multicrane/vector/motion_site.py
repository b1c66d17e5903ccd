"""The compiler: a scenario in the multi-agent motion mode as the flat arrays its kernels read.

``compile_motion_site(env)`` turns a ``MultiCraneEnv`` built with the vector env's options
(its ``Simulator``, ``Site``, start rule, reach, reward options and observation layout) into
one ``MotionSite``: a named tuple of numpy arrays and numbers, shared by every copy and never
written. Cells are the ``Site``'s linear indices into the padded grid; ragged lists (a
target's cells, its supports, the targets a component may fill) are padded with -1. The start
fields carry the names the start-drawing kernel (``multicrane.vector.paper_reset.draw_start``)
reads.

Supported: ``decisions="motion"``, ``auto=False``, any crane count the scenario accepts, with
or without crane reach, both rewards and reward modes, with or without site events (the
schedules themselves are drawn per episode, ``multicrane.vector.event_schedules``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from multicrane.core.kinds import kind_spec
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.envs.observation import COMPONENT_FEATURES
from multicrane.sim.site import WALL
from multicrane.vector.paper_site import MAX_COMPONENTS
from multicrane.vector.start_arrays import component_arrays, grid_arrays, padded

# uint8 observations: the quantities whose divisors must fit a byte, and the step fraction's
# scale (its divisor, the step limit, is larger: it is rounded down to 1/STEP_SCALE).
WHOLE_SCALES = ("height", "x extent", "y extent", "move limit", "assembly steps",
                "component count")  # fmt: skip
STEP_SCALE = 255


class MotionSite(NamedTuple):
    """Everything the motion kernels read about a scenario and the env's options."""

    # -- the grid ---------------------------------------------------------------------------
    static_occ: np.ndarray  # (P,) int8: FREE or WALL (edges, ground, sky, obstacles)
    obstacle: np.ndarray  # (P,) bool: obstacle cells inside the site (plane 0)
    move_delta: np.ndarray  # (6,) int64: linear offset of each move
    column_of: np.ndarray  # (P,) int64: the plan index x * Y + y of a cell, -1 outside
    column_base: np.ndarray  # (X * Y,) int64: linear index of (x, y, 0)
    height: int  # H: cells z = 1..H of a column
    z_of: np.ndarray  # (P,) int64: a cell's z
    # -- components and targets (targets share the component indices) ----------------------
    length: np.ndarray  # (C,) int64: cells per component (and per own target)
    waits: np.ndarray  # (C,) bool: claimable only while a compatible target is ready
    prebuilt: np.ndarray  # (C,) bool
    n_prebuilt: int
    target_cells: np.ndarray  # (C, L) int64, node 1 first, -1 padded
    target_at: np.ndarray  # (P,) int64: the target covering a cell, -1 none
    supports: np.ndarray  # (C, S) int64, -1 padded
    compatible: np.ndarray  # (C, K) int64: targets a component may fill, -1 padded
    # -- the start (``draw_start``'s fields) ------------------------------------------------
    prebuilt_on: np.ndarray  # (C, T) int64: targets a pre-built one may stand on
    fixed_cells: np.ndarray  # (C, L) int64: fixed start cells, -1 (none)
    fixed_pickup: np.ndarray  # (C, L) int64: their pick-up cells
    fixed_occ: np.ndarray  # (P,) bool: cells of the fixed starts
    drawn: np.ndarray  # (D,) int64: components drawn at random, in list order
    table_of: np.ndarray  # (C,) int64: the candidate table of a drawn component, -1 none
    table_start: np.ndarray  # (n_tables + 1,) int64: rows of each table
    cand_cells: np.ndarray  # (R, L) int64: each candidate pose's cells
    cand_pickup: np.ndarray  # (R, L) int64: its pick-up pose's cells
    cand_prob: np.ndarray  # (R,) float64: its probability under the rule
    # -- cranes and reach -------------------------------------------------------------------
    n_cranes: int
    has_reach: bool
    zone: np.ndarray  # (N, P) bool: the cells each crane reaches (all True without reach)
    zone_targets: np.ndarray  # (N, C, K) int64: compatible targets in the crane's zone
    # -- rules and reward -------------------------------------------------------------------
    assembly_steps: int
    step_limit: int  # the env's (``max_steps`` or the scenario's)
    cycle_limit: int  # ``max_cycles``, 0 for none
    move_limit: int
    completion: float
    over_limit_cost: float
    step_cost: float
    makespan: bool  # reward="makespan"
    split: bool  # reward_mode="split"
    # -- observation (``multicrane.envs.observation``) --------------------------------------
    obs_size: int  # D
    own_start: int  # the two per-crane planes
    rows_start: int  # the component table
    crane_start: int  # the crane vector
    plane_z: np.ndarray  # (H + 1,) float32: a shared plane's value for top height z
    own_z: np.ndarray  # (H + 1,) float32: a per-crane plane's value for top height z
    scaled: np.ndarray  # (P, 3) float32: a cell's (x, y, z) divided by the site size
    beam: np.ndarray  # (C,) float32: the component table's beam feature
    ratio_limit: int  # max(move_limit, 1): where the crane vector's moves are clipped
    crane_den: np.ndarray  # (4,) float64: the divisors of the crane vector's moves, assembly,
    # assembled and step fractions (in whole numbers 1, 1, 1 and the step limit)
    step_num: float  # the step fraction's numerator scale: 1, or 255 in whole numbers
    # -- site events (``multicrane.sim.events``) --------------------------------------------
    has_events: bool  # the env has an ``EventSpec``: schedules, and the events block
    events_start: int  # the observation's events block (delivered, available, closed plan)
    plan_y: int  # Y: a closure's column (x, y) is plan index x * Y + y


def compile_motion_site(env: MultiCraneEnv, whole: bool = False) -> MotionSite:
    """The arrays of ``env``'s scenario and options (ValueError for what the kernels do not
    model); ``whole``: the observation in whole numbers (``obs_scale``), for uint8."""
    sim, scenario = env.sim, env.scenario
    if scenario.n_components > MAX_COMPONENTS:
        raise ValueError(f"{scenario.name}: at most {MAX_COMPONENTS} components in the vector env")
    site = sim.site
    if int((site.target_at >= 0).sum()) != sum(site.length):
        raise ValueError(f"{scenario.name}: overlapping targets are not modelled")
    X, Y, H = scenario.size
    n = sim.n_cranes
    components = component_arrays(scenario, site)
    lay = env.observation_layout
    shape = site.shape
    return MotionSite(
        **grid_arrays(site, X, Y, H),
        obstacle=_obstacles(site, X, Y, H),
        z_of=np.broadcast_to(np.arange(H + 2), shape).reshape(-1).astype(np.int64),
        **components,
        n_cranes=n,
        has_reach=site.reach is not None,
        **_reach(sim, components["compatible"]),
        assembly_steps=scenario.assembly_steps,
        step_limit=env.step_limit,
        cycle_limit=env.max_cycles or 0,
        move_limit=site.move_limit,
        completion=float(scenario.reward.completion),
        over_limit_cost=float(scenario.reward.over_limit_cost),
        step_cost=float(scenario.reward.step_cost),
        makespan=env.reward == "makespan",
        split=env.reward_mode == "split",
        obs_size=lay.size,
        own_start=lay.own.start,
        rows_start=lay.components.start,
        crane_start=lay.crane.start,
        **_observed_values(env, X, Y, H, whole),
        beam=np.array([kind_spec(k).beam_feature for k in site.kind], dtype=np.float32),
        ratio_limit=max(site.move_limit, 1),
        has_events=sim.events is not None,
        events_start=lay.events.start,
        plan_y=Y,
    )


def _observed_values(env: MultiCraneEnv, X: int, Y: int, H: int, whole: bool) -> dict:
    """The observation's value tables and crane-vector divisors: the fractions of
    ``multicrane.envs.observation``, or with ``whole`` their numerators (``obs_scale``)."""
    site = env.sim.site
    den = _fraction_divisors(env)
    if not whole:
        return {
            "plane_z": np.arange(H + 1, dtype=np.float32) / H,
            "own_z": np.array([z / H for z in range(H + 1)], dtype=np.float32),
            "scaled": _scaled(site, X, Y, H),
            "crane_den": np.array([*den, env.step_limit], dtype=np.float64),
            "step_num": 1.0,
        }
    for what, n in zip(WHOLE_SCALES, (H, X - 1, Y - 1, *den), strict=True):
        if n > 255:
            raise ValueError(
                f"{env.scenario.name}: obs_dtype uint8 needs every scale up to 255, "
                f"the {what} is {n}"
            )
    z = np.arange(H + 1, dtype=np.float32)
    cells = [site.cell(j) for j in range(site.size)]
    return {
        "plane_z": z,
        "own_z": z,
        "scaled": np.array(cells, dtype=np.float32).reshape(site.size, 3),
        "crane_den": np.array([1, 1, 1, env.step_limit], dtype=np.float64),
        "step_num": float(STEP_SCALE),
    }


def _fraction_divisors(env: MultiCraneEnv) -> list[int]:
    """The divisors of the crane vector's moves, assembly and assembled fractions."""
    scenario = env.scenario
    return [max(env.sim.site.move_limit, 1), scenario.assembly_steps, scenario.n_components]


def obs_scale(env: MultiCraneEnv, site: MotionSite) -> np.ndarray:
    """(D,) float32: the divisor of each feature of the whole-number observation:
    ``obs.astype(np.float32) / scale`` is the float32 observation, exactly, but for the step
    fraction (``STEP_SCALE``: rounded down to 1/255)."""
    X, Y, H = env.scenario.size
    scale = np.ones(site.obs_size, dtype=np.float32)
    scale[: site.rows_start] = H  # the shared and the per-crane planes
    rows = scale[site.rows_start : site.crane_start].reshape(-1, COMPONENT_FEATURES)
    rows[:, 8:] = [max(X - 1, 1), max(Y - 1, 1), H] * 2  # node 1 and node 2 (x, y, z)
    v = site.crane_start
    scale[[v + 3, v + 5, v + 7]] = _fraction_divisors(env)
    scale[v + 8] = STEP_SCALE
    if site.has_events:
        scale[site.events_start + len(site.length) + site.n_cranes :] = H  # the closed plan
    return scale


def _obstacles(site, X: int, Y: int, H: int) -> np.ndarray:
    inside = np.zeros(site.shape, dtype=bool)
    inside[1 : X + 1, 1 : Y + 1, 1 : H + 1] = True
    return inside.reshape(-1) & (site.static == WALL)


def _reach(sim, compatible: np.ndarray) -> dict[str, np.ndarray]:
    """Each crane's zone and, per component, the compatible targets inside it."""
    site, n = sim.site, sim.n_cranes
    if site.reach is None:
        zone = np.ones((n, site.size), dtype=bool)
        return {"zone": zone, "zone_targets": np.repeat(compatible[None], n, axis=0)}
    zone = np.stack([site.reach[k] for k in range(n)])
    cells = site.target_cells
    rows = [
        [[t for t in targets if site.reaches(k, cells[t])] for targets in site.compatible]
        for k in range(n)
    ]
    width = compatible.shape[1]
    return {"zone": zone, "zone_targets": np.stack([padded(r, width) for r in rows])}


def _scaled(site, X: int, Y: int, H: int) -> np.ndarray:
    """The component table's node coordinates: a cell's (x, y, z) times the observer's
    scale, computed in float64 and stored as float32, as ``Observer`` does."""
    scale = (1.0 / max(X - 1, 1), 1.0 / max(Y - 1, 1), 1.0 / H)
    rows = [[v * f for v, f in zip(site.cell(j), scale, strict=True)] for j in range(site.size)]
    return np.array(rows, dtype=np.float32).reshape(site.size, 3)

