"""Table-driven rule tests on small hand-built sites.

The micro site (8 x 8 x 6): two columns lying in the yard, a beam resting on both column
targets, optional obstacles. Coordinates are (x, y, z) with z up; ``lin`` and ``cells`` convert
between site cells and the simulator's linear indices.
"""

from __future__ import annotations

import numpy as np
import pytest

from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, WAIT, EventType, Move, Status
from multicrane.core.schema import RewardSpec
from multicrane.envs.reward import split, team_reward
from multicrane.scenario.loader import parse_scenario
from multicrane.sim.simulator import Simulator

C1, C2, B1 = 0, 1, 2  # component indices in the micro site


def micro_site(
    interchangeable: bool = False,
    obstacles: str = "",
    cranes: int = 1,
    assembly_steps: int = 1,
    c1_initial: str = "[[1, 1, 1], [1, 4, 1]]",
    c2_initial: str = "[[2, 1, 1], [2, 4, 1]]",
    b1_initial: str = "[[0, 6, 1], [2, 6, 1]]",
    order: str = '["c1", "c2", "b1"]',
    extra: str = "",
) -> str:
    return f"""
format = 1
name = "micro"
[site]
size = [8, 8, 6]
construction_area = {{ min = [4, 0], max = [7, 7] }}
foundations = [[5, 2], [5, 6]]
obstacles = [{obstacles}]
[rules]
cranes = {cranes}
step_limit = 50
interchangeable_targets = {str(interchangeable).lower()}
assembly_steps = {assembly_steps}
order = {order}
[[components]]
id = "c1"
kind = "column"
length = 4
initial = {c1_initial}
target = [[5, 2, 1], [5, 2, 4]]
[[components]]
id = "c2"
kind = "column"
length = 4
initial = {c2_initial}
target = [[5, 6, 1], [5, 6, 4]]
[[components]]
id = "b1"
kind = "beam"
length = 3
initial = {b1_initial}
target = [[5, 3, 4], [5, 5, 4]]
supports = ["c1", "c2"]
{extra}
"""


def make(text: str | None = None, n_cranes: int | None = None, auto: bool = False) -> Simulator:
    sim = Simulator(
        parse_scenario(text or micro_site(), "micro.toml"), n_cranes=n_cranes, auto=auto
    )
    sim.reset(np.random.default_rng(0))
    return sim


def cells(sim: Simulator, comp: int) -> list[tuple[int, int, int]]:
    return [sim.site.cell(j) for j in sim.state.cells[comp]]


def column_at(x: int, y: int, z0: int, length: int = 4) -> list[tuple[int, int, int]]:
    return [(x, y, z) for z in range(z0, z0 + length)]


def types(out) -> list[EventType]:
    return [e.type for e in out.events]


def drive(sim: Simulator, comp: int, moves: list[Move], crane: int = 0) -> list:
    """Apply moves one step each with the other cranes waiting; return the outcomes."""
    outs = []
    for m in moves:
        actions = [WAIT] * sim.n_cranes
        actions[crane] = int(m)
        outs.append(sim.step(actions))
    return outs


X_MINUS, Y_MINUS, X_PLUS, Y_PLUS, UP, DOWN = list(Move)

# c1 lifted: upright at (1, 1, 2..5); path to its target (5, 2, 1..4).
C1_TO_TARGET = [Y_PLUS] + [X_PLUS] * 4 + [DOWN]
# c2 lifted: upright at (2, 1, 2..5); path to its target (5, 6, 1..4) that avoids c1's.
C2_TO_TARGET = [Y_PLUS] * 5 + [X_PLUS] * 3 + [DOWN]


# -- pick-up poses -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "comp", "expected"),
    [
        # A column lying along y is stood upright on node 1 and raised by one.
        ({}, C1, column_at(1, 1, 2)),
        # Node order decides where: node 1 at the far end.
        ({"c1_initial": "[[1, 4, 1], [1, 1, 1]]"}, C1, column_at(1, 4, 2)),
        # A column lying along x.
        ({"c1_initial": "[[3, 0, 1], [0, 0, 1]]"}, C1, column_at(3, 0, 2)),
        # A beam lying along x is turned about its centre (1, 6) to its target's axis (y)
        # and raised to its target's height (z = 4).
        ({}, B1, [(1, 5, 4), (1, 6, 4), (1, 7, 4)]),
        # Centre rounds down: (0..2, 5) has centre (1, 5).
        ({"b1_initial": "[[0, 5, 1], [2, 5, 1]]"}, B1, [(1, 4, 4), (1, 5, 4), (1, 6, 4)]),
    ],
)
def test_pickup_pose(kwargs, comp, expected):
    sim = make(micro_site(**kwargs))
    assert [sim.site.cell(j) for j in sim.state.pickup[comp]] == expected


def test_claim_lifts_to_pickup_pose_and_frees_the_yard_cells():
    sim = make()
    yard = list(sim.state.cells[C1])
    out = sim.step([CLAIM_BASE + C1])
    assert types(out) == [EventType.CLAIMED, EventType.LIFTED]
    assert cells(sim, C1) == column_at(1, 1, 2)
    assert (
        sim.state.status[C1] == Status.IN_TRANSIT
        and sim.state.held[0] == C1
        and sim.state.holder[C1] == 0
    )
    # Its old cells are free at once; the lifted column may go down into node 1's cell.
    assert all(sim.state.occ[j] == 0 for j in yard[1:])
    sim.step([int(DOWN)])
    assert cells(sim, C1) == column_at(1, 1, 1)


def test_claim_blocked_when_pickup_pose_is_occupied():
    # Crane 0 parks c2 upright exactly where c1 would be lifted to: c1 is then not claimable,
    # and a claim sent anyway leaves it in the yard.
    text = micro_site(c1_initial="[[1, 0, 1], [1, 3, 1]]", c2_initial="[[3, 0, 1], [3, 3, 1]]")
    sim = make(text, n_cranes=2)
    assert sim.action_mask(1)[CLAIM_BASE + C1]
    sim.step([CLAIM_BASE + C2, WAIT])
    drive(sim, C2, [X_MINUS, X_MINUS])
    assert cells(sim, C2) == column_at(1, 0, 2)
    assert not sim.action_mask(1)[CLAIM_BASE + C1]
    out = sim.step([WAIT, CLAIM_BASE + C1])
    assert types(out) == [EventType.LIFT_BLOCKED]
    assert sim.state.status[C1] == Status.INITIAL and sim.state.held[1] == -1


# -- blocked moves ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("obstacles", "before", "move", "why"),
    [
        ("", [X_MINUS], X_MINUS, "the site's edge (x = -1)"),
        ("", [Y_MINUS], Y_MINUS, "the site's edge (y = -1)"),
        ("", [UP], UP, "the sky (z = 7 > height 6)"),
        ("", [DOWN], DOWN, "the ground (z = 0)"),
        ("{ min = [1, 2, 3], max = [1, 2, 3] }", [], Y_PLUS, "an obstacle"),
        ("", [X_PLUS], DOWN, "another component (c2 lying at z = 1)"),
    ],
)
def test_blocked_move(obstacles, before, move, why):
    sim = make(micro_site(obstacles=obstacles))
    sim.step([CLAIM_BASE + C1])
    drive(sim, C1, before)
    moves_before = int(sim.state.moves[C1])
    where = cells(sim, C1)
    assert not sim.action_mask(0)[int(move)], why
    out = sim.step([int(move)])
    assert types(out) == [EventType.BLOCKED], why
    assert cells(sim, C1) == where
    assert sim.state.moves[C1] == moves_before  # a blocked move does not count


def test_successful_moves_count():
    sim = make()
    sim.step([CLAIM_BASE + C1])
    drive(sim, C1, [X_PLUS, Y_PLUS, UP])
    assert sim.state.moves[C1] == 3
    assert cells(sim, C1) == column_at(2, 2, 3)


# -- arrival ------------------------------------------------------------------------------


def test_arrival_at_own_target_then_assembly():
    sim = make()
    sim.step([CLAIM_BASE + C1])
    outs = drive(sim, C1, C1_TO_TARGET)
    assert EventType.ARRIVED in types(outs[-1])
    assert sim.state.status[C1] == Status.ARRIVED and sim.state.filled[C1] == C1
    mask = sim.action_mask(0)
    assert mask[ASSEMBLE] and not mask[: int(WAIT)].any()  # an arrived component never moves
    out = sim.step([ASSEMBLE])
    assert types(out) == [EventType.ASSEMBLY_STARTED, EventType.ASSEMBLED]
    assert (
        sim.state.status[C1] == Status.ASSEMBLED
        and sim.state.held[0] == -1
        and sim.state.n_assembled == 1
    )


@pytest.mark.parametrize(("interchangeable", "arrives"), [(False, False), (True, True)])
def test_arrival_at_another_components_target(interchangeable, arrives):
    # c1 goes to c2's target (5, 6): only with interchangeable targets is that an arrival.
    sim = make(micro_site(interchangeable=interchangeable))
    sim.step([CLAIM_BASE + C1])
    outs = drive(sim, C1, [X_PLUS] * 4 + [Y_PLUS] * 5 + [DOWN])
    assert cells(sim, C1) == column_at(5, 6, 1)
    assert (EventType.ARRIVED in types(outs[-1])) == arrives
    assert sim.state.status[C1] == (Status.ARRIVED if arrives else Status.IN_TRANSIT)
    if arrives:
        assert sim.state.filled[C1] == C2 and sim.state.filled_by[C2] == C1
        # c2 may now only go to the other free target, c1's own.
        assert sim.ready_targets(C2) == [C1]


def test_filled_target_cannot_be_filled_again():
    sim = make(micro_site(interchangeable=True), n_cranes=2)
    sim.step([CLAIM_BASE + C1, CLAIM_BASE + C2])
    drive(sim, C1, C1_TO_TARGET, crane=0)
    assert sim.state.status[C1] == Status.ARRIVED
    assert sim.ready_targets(C2) == [C2]  # c1's target is taken


# -- precedence ---------------------------------------------------------------------------


def test_beam_not_claimable_until_a_supported_target_exists():
    sim = make(n_cranes=1)
    assert not sim.action_mask(0)[CLAIM_BASE + B1]
    out = sim.step([CLAIM_BASE + B1])
    assert types(out) == [EventType.ILLEGAL] and sim.state.status[B1] == Status.INITIAL


def build_columns(sim: Simulator) -> None:
    sim.step([CLAIM_BASE + C1])
    drive(sim, C1, C1_TO_TARGET)
    sim.step([ASSEMBLE])
    sim.step([CLAIM_BASE + C2])
    drive(sim, C2, C2_TO_TARGET)
    assert sim.state.status[C2] == Status.ARRIVED


def test_beam_covering_its_target_before_supports_are_assembled_does_not_arrive():
    sim = make()
    build_columns(sim)  # c1 assembled, c2 only arrived
    assert not sim.target_ready[B1]
    sim.step([ASSEMBLE])
    assert sim.target_ready[B1]
    sim.step([CLAIM_BASE + B1])
    assert cells(sim, B1) == [(1, 5, 4), (1, 6, 4), (1, 7, 4)]
    outs = drive(sim, B1, [Y_MINUS] * 2 + [X_PLUS] * 4)
    assert cells(sim, B1) == [(5, 3, 4), (5, 4, 4), (5, 5, 4)]
    assert EventType.ARRIVED in types(outs[-1])


def test_precedence_blocks_arrival_in_automatic_mode():
    # A beam whose supports are not assembled is skipped by the pointer: with the order
    # b1, c1, c2 the crane gets c1 first.
    sim = make(micro_site(order='["b1", "c1", "c2"]'), auto=True)
    assert sim.state.held[0] == C1
    assert sim.state.status[C1] == Status.INITIAL  # assigned, not yet lifted


# -- automatic mode -----------------------------------------------------------------------


def test_auto_first_move_lifts_and_moves():
    sim = make(auto=True)
    out = sim.step([int(X_PLUS)])
    assert types(out) == [EventType.LIFTED]
    assert cells(sim, C1) == column_at(2, 1, 2) and sim.state.moves[C1] == 1


def test_auto_first_move_blocked_still_lifts():
    sim = make(auto=True)
    out = sim.step([int(Y_MINUS)])  # (1, 0) is free: allowed
    assert sim.state.moves[C1] == 1
    sim = make(micro_site(c1_initial="[[1, 0, 1], [1, 3, 1]]"), auto=True)
    out = sim.step([int(Y_MINUS)])  # y = -1: blocked after lifting
    assert types(out) == [EventType.LIFTED, EventType.BLOCKED]
    assert cells(sim, C1) == column_at(1, 0, 2) and sim.state.moves[C1] == 0


def test_auto_assembles_on_arrival_and_assigns_next():
    sim = make(auto=True)
    outs = drive(sim, C1, C1_TO_TARGET)
    assert types(outs[-1])[-3:] == [EventType.ARRIVED, EventType.ASSEMBLED, EventType.ASSIGNED]
    assert sim.state.status[C1] == Status.ASSEMBLED and sim.state.held[0] == C2


def test_auto_pass_over_of_a_prebuilt_entry():
    # c1 pre-built and listed: reaching it costs one pass-over step (the paper's Env1 quirk).
    text = micro_site(order='["c2", "c1", "b1"]').replace(
        "initial = [[1, 1, 1], [1, 4, 1]]\ntarget = [[5, 2, 1], [5, 2, 4]]",
        "target = [[5, 2, 1], [5, 2, 4]]\nprebuilt = true",
    )
    sim = make(text, auto=True)
    assert sim.state.held[0] == C2 and sim.state.n_assembled == 1
    drive(sim, C2, C2_TO_TARGET)
    assert sim.state.pass_over[0] and sim.state.held[0] == -1
    out = sim.step([int(X_PLUS)])  # the action is ignored
    assert types(out)[0] == EventType.PASS_OVER
    assert out.pass_over_by == [0] and sim.state.held[0] == B1


# -- several cranes in one step -----------------------------------------------------------


@pytest.mark.parametrize("order", [[0, 1], [1, 0]])
def test_claim_conflict_goes_to_the_earlier_crane(order):
    sim = make(n_cranes=2)
    out = sim.step([CLAIM_BASE + C1, CLAIM_BASE + C1], order)
    winner, loser = order
    assert sim.state.held[winner] == C1 and sim.state.held[loser] == -1
    conflicts = [e for e in out.events if e.type == EventType.CLAIM_CONFLICT]
    assert [(e.crane, e.component) for e in conflicts] == [(loser, C1)]


@pytest.mark.parametrize("order", [[0, 1], [1, 0]])
def test_two_components_moving_into_the_same_cell(order):
    # c1 upright at (1, 1), c2 upright at (3, 1): both move towards x = 2.
    text = micro_site(c2_initial="[[3, 1, 1], [3, 4, 1]]")
    sim = make(text, n_cranes=2)
    sim.step([CLAIM_BASE + C1, CLAIM_BASE + C2])
    out = sim.step([int(X_PLUS), int(X_MINUS)], order)
    first, second = order
    moved = {0: C1, 1: C2}
    expected_x = {C1: 2, C2: 2}
    assert cells(sim, moved[first])[0][0] == expected_x[moved[first]]
    blocked = [e for e in out.events if e.type == EventType.BLOCKED]
    assert [e.crane for e in blocked] == [second]
    occupied = [j for c in (C1, C2) for j in sim.state.cells[c]]
    assert len(occupied) == len(set(occupied))


def test_following_into_a_vacated_cell_is_allowed_in_order():
    # c1 at x = 1 follows c2 (x = 2) moving on to x = 3, when c2 acts first.
    text = micro_site(c2_initial="[[2, 1, 1], [2, 4, 1]]")
    sim = make(text, n_cranes=2)
    sim.step([CLAIM_BASE + C1, CLAIM_BASE + C2])
    sim.step([int(X_PLUS), int(X_PLUS)], [1, 0])
    assert cells(sim, C2)[0][0] == 3 and cells(sim, C1)[0][0] == 2
    # And a swap is impossible: two components cannot pass through each other.
    out = sim.step([int(X_PLUS), int(X_MINUS)], [0, 1])
    assert [e.type for e in out.events] == [EventType.BLOCKED, EventType.BLOCKED]


# -- assembly time ------------------------------------------------------------------------


def test_assembly_takes_the_scenarios_steps():
    sim = make(micro_site(assembly_steps=3))
    sim.step([CLAIM_BASE + C1])
    drive(sim, C1, C1_TO_TARGET)
    out = sim.step([ASSEMBLE])
    assert types(out) == [EventType.ASSEMBLY_STARTED]
    assert sim.action_mask(0).tolist() == [0] * 6 + [1] + [0] * (sim.site.n_actions - 7)
    assert types(sim.step([WAIT])) == []
    out = sim.step([WAIT])
    assert types(out) == [EventType.ASSEMBLED] and sim.state.held[0] == -1


# -- illegal actions ----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("action", "detail"),
    [
        (int(X_PLUS), "move"),  # holds nothing
        (ASSEMBLE, "assemble"),  # holds nothing
        (CLAIM_BASE + B1, "claim"),  # beam with no supported target
    ],
)
def test_illegal_action_is_a_noop_event(action, detail):
    sim = make()
    before = sim.state.occ.copy()
    out = sim.step([action])
    assert types(out) == [EventType.ILLEGAL] and detail in out.events[0].detail
    assert np.array_equal(before, sim.state.occ)


# -- reward -------------------------------------------------------------------------------

PAPER = RewardSpec()


@pytest.mark.parametrize(
    ("n_progress", "n_assembled", "k", "complete", "over", "expected"),
    [
        (0, 0, 0, False, False, -1.0),  # plain step: -1 / (k + 1)
        (0, 2, 2, False, False, -1 / 3),
        (0, 2, 1, False, False, -0.5),  # a pre-built component counts in N, not in k
        (0, 1, 1, False, True, -2.0),  # past the move limit
        (1, 2, 2, False, True, 2.0),  # an arrival pays N, even past the limit
        (1, 3, 3, True, False, 10.0),  # the last arrival pays the completion reward
        (2, 4, 4, False, False, 8.0),  # two assemblies in one step (several cranes)
    ],
)
def test_team_reward(n_progress, n_assembled, k, complete, over, expected):
    assert team_reward(PAPER, n_progress, n_assembled, k, complete, over) == pytest.approx(expected)


def test_reward_split_adds_up():
    assert split(-1.0, 4, [], []) == [-0.25] * 4
    assert split(-2.0, 3, [], [1]) == [0.0, -2.0, 0.0]
    terms = split(6.0, 3, [0, 2], [1])
    assert terms == [3.0, 0.0, 3.0] and sum(terms) == 6.0


def test_move_limit_cost_starts_with_the_16th_move():
    from multicrane.envs.crane_env import MultiCraneEnv

    env = MultiCraneEnv(parse_scenario(micro_site(), "micro.toml"), auto=True)
    env.reset(seed=0)
    rewards = []
    for i in range(18):
        move = X_PLUS if i % 2 == 0 else X_MINUS  # back and forth: never arrives
        _, r, *_ = env.step({"crane_0": int(move)})
        rewards.append(r["crane_0"])
    assert rewards[:15] == [-1.0] * 15
    assert rewards[15:] == [-2.0] * 3


@pytest.mark.parametrize("name", ["e3s2", "hall-4c"])
def test_grid_coords_are_the_cells_of_every_linear_index(name):
    """``Site.grid_coords``: every linear index's ``Site.cell`` shifted by (1, 1, 0) (the
    padding), whole or for given indices, and ``lin`` of it gives the index back."""
    import multicrane

    site = Simulator(multicrane.load_scenario(name)).site
    every = site.grid_coords()
    assert every.shape == (site.size, 3) and every.dtype == np.int64
    expected = np.array([site.cell(j) for j in range(site.size)]) + (1, 1, 0)
    assert np.array_equal(every, expected)
    some = [0, 7, site.size - 1]
    assert np.array_equal(site.grid_coords(some), expected[some])
    assert all(site.lin(*(every[j] - (1, 1, 0))) == j for j in range(0, site.size, 97))
