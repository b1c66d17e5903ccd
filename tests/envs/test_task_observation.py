"""The compiled task observation against its numpy specification, on states drawn at random.

``TaskObserver`` fills the ``components`` table with ``component_rows_kernel`` and every
crane's row of one array; ``reference_observations`` below is the numpy code it replaced, per
crane and per column as ``multicrane.envs.task_observation`` describes them. Hypothesis draws
scenarios (with and without site events and site planes), seeds and random legal task rounds;
the observations must be equal bit for bit.
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import multicrane
from multicrane.core.codes import Status
from multicrane.envs.task_observation import COMPONENT_FEATURES, TASK_FEATURES
from multicrane.episodes.random_actions import random_legal_action
from multicrane.sim.simulator import NOBODY


def _nodes(observer, cells):
    site = observer.sim.site
    a = np.array(site.cell(cells[0]), dtype=np.float32) / observer.scale
    b = np.array(site.cell(cells[-1]), dtype=np.float32) / observer.scale
    return [*a, *b]


def reference_component_rows(observer) -> np.ndarray:
    """The ``components`` table by numpy, component by component (the specification)."""
    sim, book = observer.sim, observer.book
    st_ = sim.state
    C, N = sim.site.n_components, sim.n_cranes
    events = observer.layout.events is not None
    comp = np.zeros((C, len(COMPONENT_FEATURES) + N + events), dtype=np.float32)
    status = np.asarray(st_.status)
    comp[:, 0] = observer._beam
    comp[np.arange(C), 1 + status] = 1.0
    for c in range(C):
        cells = st_.cells[c] if st_.cells[c] else st_.pickup[c]
        if cells:
            comp[c, 5:11] = _nodes(observer, cells)
    comp[:, 11:17] = observer._targets
    comp[:, 17] = sim.target_ready
    comp[sim.claimable_components(), 18] = 1.0
    for p in book.task:
        if p != NOBODY:
            comp[book.tasks.comp[p], 19] = 1.0
    lens = np.where(book.static_ok, book.static_len, np.iinfo(np.int64).max)
    free_t = np.asarray(st_.filled_by) == NOBODY
    best = np.full(C, np.inf)
    pair_len = lens.min(axis=0).astype(np.float64)
    pair_len[~free_t[book.tasks.target]] = np.inf
    np.minimum.at(best, book.tasks.comp, pair_len)
    path = np.where(np.isfinite(best), np.minimum(best / observer.D, 1.0), 1.0)
    path[status != int(Status.INITIAL)] = 0.0
    comp[:, 20] = path
    can = np.zeros((N, C), dtype=bool)
    for k in range(N):
        np.logical_or.at(can[k], book.tasks.comp, book.static_ok[k])
    comp[:, 21 : 21 + N] = can.T
    if events:
        late = ~np.asarray(st_.delivered)
        comp[late, :11] = 0.0
        comp[late, 17:] = 0.0
        comp[:, -1] = st_.delivered
    return comp


def reference_observations(observer) -> list[np.ndarray]:
    """Every crane's flat observation, table by table (planes excluded: the motion
    observer's own, tested with it)."""
    sim, book = observer.sim, observer.book
    comp = reference_component_rows(observer)
    cranes = observer._crane_rows()
    C, N, P = sim.site.n_components, sim.n_cranes, len(book.tasks)
    tasks = np.zeros((P, len(TASK_FEATURES)), dtype=np.float32)
    tasks[:, 0] = book.tasks.comp / max(C - 1, 1)
    tasks[:, 1:7] = observer._targets[book.tasks.target]
    dist = np.where(book.static_ok, np.minimum(book.static_len / observer.D, 1.0), 1.0)
    masks = book.masks()
    out = []
    for k in range(N):
        cr = cranes.copy()
        cr[k, 0] = 1.0
        tk = tasks.copy()
        tk[:, 7] = dist[k]
        tk[:, 8] = masks[k, 1:]
        parts = [comp.ravel(), cr.ravel(), tk.ravel()]
        if observer.layout.events is not None:
            parts.append(observer._closed_plan())
        out.append(np.concatenate(parts).astype(np.float32, copy=False))
    return out


SITES = [("e2s2", 2, {}), ("hall-4c", 4, {}), ("towers-3c", 3, {}), ("e3s2", 2, {"events": "high"}),
         ("hall-4c", 3, {"events": "high"}), ("e2s2", 2, {"task_site_planes": True})]  # fmt: skip


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(SITES), st.integers(0, 10_000), st.integers(0, 30))
def test_observations_are_the_specification(site, seed, rounds):
    scenario, n, options = site
    env = multicrane.parallel_env(scenario, n_cranes=n, decisions="task", **options)
    observations, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    observer = env.unwrapped.mode.observer
    for _ in range(rounds + 1):
        if not env.agents:
            return
        rows = observer.observe_all()
        expected = reference_observations(observer)
        for k in range(n):
            head = expected[k].size  # the planes, if any, come after
            assert rows[k].dtype == np.float32
            assert np.array_equal(rows[k][:head], expected[k])
            assert np.array_equal(observations[env.possible_agents[k]]["observation"], rows[k])
        actions = {}
        for a in env.agents:
            mask = observations[a]["action_mask"]
            actions[a] = random_legal_action(mask, rng) if mask[1:].any() else 0
        observations, *_ = env.step(actions)
