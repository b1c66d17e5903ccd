"""Crane reach (tower cranes with a base and a plan radius): format, loader, rules, planners.

Hand-built small scenarios, table-driven: the zone geometry; the loader's errors (each names
the key, the value or the component); claims and moves masked outside a crane's zone and
refused when forced; the ``n_cranes`` override; automatic mode; and the shipped tower-crane
scenario solved by greedy and by the prioritized planner with every carried component inside
its crane's zone at every step. Scenarios without reach are covered by the golden tests.
"""

from __future__ import annotations

import numpy as np
import pytest

import multicrane
from multicrane.core.codes import CLAIM_BASE, WAIT, EventType, Move, Status
from multicrane.core.schema import ScenarioError
from multicrane.scenario.loader import load_scenario, parse_scenario
from multicrane.sim.reach import crane_count_problem, uncarriable
from multicrane.sim.shortest_paths import fits_everywhere, zone_ok
from multicrane.sim.simulator import NOBODY, Simulator
from multicrane.sim.site import Site
from policies.greedy import GreedyPolicy
from policies.prioritized import PrioritizedPlanner

# One column lying in the yard (picked up standing on (3, 2), z 2..5) and its target at (9, 2).
# Crane 0 stands at (6, 2) and reaches 3.5 cells: the pick-up pose, the target and the straight
# way between them, but not x = 2. Crane 1 stands at (10, 2) and reaches only around the target.
STRIP = """\
format = 1
name = "strip"

[site]
size = [12, 5, 6]
construction_area = { min = [7, 0], max = [11, 4] }
foundations = [[9, 2]]

[rules]
step_limit = 50
%RULES%

%CRANES%

[[components]]
id = "c1"
kind = "column"
length = 4
initial = [[3, 2, 1], [0, 2, 1]]
target = [[9, 2, 1], [9, 2, 4]]
"""

WIDE = "[[crane]]\nbase = [6, 2]\nradius = 3.5\n"
NARROW = "[[crane]]\nbase = [10, 2]\nradius = 1.5\n"


def strip(cranes: str = WIDE + "\n" + NARROW, rules: str = "") -> str:
    return STRIP.replace("%CRANES%", cranes).replace("%RULES%", rules)


def sim_of(text: str, n_cranes: int | None = None, auto: bool = False) -> Simulator:
    sim = Simulator(parse_scenario(text, source="strip.toml"), n_cranes=n_cranes, auto=auto)
    sim.reset(np.random.default_rng(0))
    return sim


# -- format and zone geometry --------------------------------------------------------------------


def test_crane_specs_are_parsed_and_set_the_crane_count():
    s = parse_scenario(strip(), source="strip.toml")
    assert [(c.base, c.radius) for c in s.crane_specs] == [((6, 2), 3.5), ((10, 2), 1.5)]
    assert s.cranes == 2
    assert parse_scenario(strip(rules="cranes = 2"), source="strip.toml").cranes == 2


@pytest.mark.parametrize(
    ("cell", "inside"),
    [
        ((6, 2, 1), True),  # the base column, every height
        ((6, 2, 6), True),
        ((9, 2, 3), True),  # distance 3
        ((3, 2, 3), True),
        ((2, 2, 3), False),  # distance 4
        ((9, 3, 1), True),  # sqrt(10) = 3.16
        ((9, 4, 1), False),  # sqrt(13) = 3.61
        ((6, 4, 5), True),  # distance 2
        ((10, 2, 2), False),  # distance 4
    ],
)
def test_zone_is_the_disc_around_the_base_at_every_height(cell, inside):
    site = Site(parse_scenario(strip(), source="strip.toml"))
    assert site.reach is not None and len(site.reach) == 2
    assert bool(site.reach[0][site.lin(*cell)]) is inside
    assert site.reaches(0, [site.lin(*cell)]) is inside


def test_no_reach_means_no_zones():
    site = Site(load_scenario("e2s2"))
    assert site.reach is None and site.reaches(0, [0, 1, 2])
    assert zone_ok(site, 0, [0, 1]) is None
    assert crane_count_problem(load_scenario("e2s2"), 4) is None


def test_zone_ok_is_the_shape_wholly_in_the_zone():
    site = Site(parse_scenario(strip(), source="strip.toml"))
    rel = [0, 1, 2, 3]  # an upright column
    assert np.array_equal(zone_ok(site, 0, rel), fits_everywhere(site.reach[0], rel))
    assert zone_ok(site, 0, rel)[site.lin(3, 2, 2)]
    assert not zone_ok(site, 0, rel)[site.lin(2, 2, 2)]


# -- loader errors -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("cranes", "rules", "fragments"),
    [
        ("[[crane]]\nbase = [12, 2]\nradius = 3\n", "", ["crane[0].base", "[12, 2]", "outside"]),
        ("[[crane]]\nbase = [-1, 2]\nradius = 3\n", "", ["crane[0].base", "[-1, 2]", "outside"]),
        ("[[crane]]\nbase = [6, 2]\nradius = 0\n", "", ["crane[0].radius", "0.0", "above 0"]),
        ("[[crane]]\nbase = [6, 2]\nradius = -2\n", "", ["crane[0].radius", "-2.0", "above 0"]),
        ("[[crane]]\nbase = [6, 2]\nradius = nan\n", "", ["crane[0].radius", "nan", "finite"]),
        ("[[crane]]\nbase = [6, 2]\nradius = inf\n", "", ["crane[0].radius", "inf", "finite"]),
        ("[[crane]]\nbase = [6, 2]\nradius = '3'\n", "", ["crane[0].radius", "'3'", "float"]),
        ("[[crane]]\nbase = [6, 2]\nradius = true\n", "", ["crane[0].radius", "True"]),
        ("[[crane]]\nbase = [6]\nradius = 3\n", "", ["crane[0].base", "[6]", "2 integers"]),
        ("[[crane]]\nbase = [6, 2]\n", "", ["crane[0].radius", "missing"]),
        ("[[crane]]\nbase = [6, 2]\nradius = 3\nheight = 9\n", "", ["crane[0].height", "unknown"]),
        (WIDE, "cranes = 2", ["rules.cranes = 2", "1 [[crane]]"]),
        # Uncarriable: crane 0 reaches the pick-up pose, not the target.
        ("[[crane]]\nbase = [3, 2]\nradius = 3\n", "", ["components[0]", "'c1'", "[[3, 2, 1], [0, 2, 1]]", "crane 0: base [3, 2], radius 3"]),  # noqa: E501
        # Uncarriable: each crane reaches one end only (no hand-over).
        ("[[crane]]\nbase = [3, 2]\nradius = 3\n\n" + NARROW, "", ["'c1'", "any crane", "hand-over"]),  # noqa: E501
    ],
)
def test_loader_rejects_bad_reach(cranes, rules, fragments):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(strip(cranes, rules), source="strip.toml")
    message = str(err.value)
    assert message.startswith("strip.toml: ")
    for fragment in fragments:
        assert fragment in message, (fragment, message)


def test_an_empty_crane_list_is_refused():
    text = strip("").replace('name = "strip"', 'name = "strip"\ncrane = []')
    with pytest.raises(ScenarioError, match=r"strip.toml: crane = \[\]: needs at least one"):
        parse_scenario(text, source="strip.toml")


def test_loader_checks_every_random_start_pose():
    # c1 drawn lying along +x with node 1 at x in the band, y in 1..3: picked up standing on
    # node 1. From x = 3 the pick-up pose is within 3.5 cells of crane 0's base; from x = 2 not.
    band = '\n[random_start]\nbands = [{ x = [3, 3], y = [1, 3] }]\ndirections = ["+x"]\n'
    text = strip(WIDE).replace("initial = [[3, 2, 1], [0, 2, 1]]\n", "") + band
    assert parse_scenario(text, source="strip.toml").random_start is not None
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text.replace("x = [3, 3]", "x = [2, 3]"), source="strip.toml")
    assert "'c1' starting at [[2, 1, 1], [5, 1, 1]]" in str(err.value)


def test_a_target_nobody_can_fill_is_rejected():
    # Two interchangeable columns: crane 0 can carry each to the near target, but nobody
    # reaches the far target at (11, 2).
    text = strip(WIDE, "interchangeable_targets = true").replace(
        "foundations = [[9, 2]]", "foundations = [[9, 2], [11, 2]]"
    ) + (
        '\n[[components]]\nid = "c2"\nkind = "column"\nlength = 4\n'
        "initial = [[3, 4, 1], [0, 4, 1]]\ntarget = [[11, 2, 1], [11, 2, 4]]\n"
    )
    text = text.replace("initial = [[3, 4, 1], [0, 4, 1]]", "initial = [[4, 1, 1], [1, 1, 1]]")
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, source="strip.toml")
    assert "the target of component 'c2'" in str(err.value)
    assert "cannot be filled" in str(err.value)


# -- n_cranes ------------------------------------------------------------------------------------


def test_n_cranes_above_the_described_cranes_is_refused():
    with pytest.raises(ValueError, match=r"n_cranes = 3.*describes 2 cranes"):
        Simulator(parse_scenario(strip(), source="strip.toml"), n_cranes=3)


def test_n_cranes_leaving_a_component_uncarriable_is_refused():
    # The narrow crane first: alone it cannot carry c1.
    text = strip(NARROW + "\n" + WIDE)
    Simulator(parse_scenario(text, source="strip.toml"))  # both cranes: fine
    with pytest.raises(ValueError, match=r"component 'c1'.*crane 0 \(the only one used\)"):
        Simulator(parse_scenario(text, source="strip.toml"), n_cranes=1)
    with pytest.raises(ValueError, match="component 'c1'"):
        multicrane.parallel_env(parse_scenario(text, source="strip.toml"), n_cranes=1)


def test_default_n_cranes_is_the_number_of_cranes_described():
    assert Simulator(parse_scenario(strip(), source="strip.toml")).n_cranes == 2
    assert Simulator(parse_scenario(strip(WIDE), source="strip.toml")).n_cranes == 1


# -- claims and moves ----------------------------------------------------------------------------


def test_claim_is_masked_for_a_crane_that_cannot_reach_the_pickup():
    sim = sim_of(strip())
    masks = sim.action_masks()
    assert masks[0][CLAIM_BASE + 0] == 1  # the wide crane
    assert masks[1][CLAIM_BASE + 0] == 0  # the narrow crane: pick-up pose out of reach
    assert sim.in_reach(0, 0) and not sim.in_reach(1, 0)


def test_forced_claim_out_of_reach_does_nothing_and_says_reach():
    sim = sim_of(strip())
    out = sim.step([WAIT, CLAIM_BASE + 0])
    assert [(e.type, e.detail) for e in out.events] == [(EventType.ILLEGAL, "reach")]
    assert list(sim.state.held) == [NOBODY, NOBODY]
    assert sim.state.status[0] == Status.INITIAL


@pytest.mark.parametrize(
    ("move", "allowed"),
    [
        (Move.X_MINUS, False),  # to x = 2: distance 4 from the base
        (Move.X_PLUS, True),
        (Move.Y_MINUS, True),  # (3, 1): sqrt(10)
        (Move.Y_PLUS, True),
        (Move.UP, True),  # reach holds at every height
        (Move.DOWN, True),
    ],
)
def test_move_out_of_the_zone_is_masked_and_blocked_when_forced(move, allowed):
    sim = sim_of(strip())
    sim.step([CLAIM_BASE + 0, WAIT])
    assert sim.state.status[0] == Status.IN_TRANSIT
    before = list(sim.state.cells[0])
    assert sim.action_masks()[0][int(move)] == int(allowed)
    out = sim.step([int(move), WAIT])
    if allowed:
        assert sim.state.cells[0] != before
        assert not [e for e in out.events if e.type == EventType.BLOCKED]
    else:
        assert sim.state.cells[0] == before
        assert [(e.type, e.detail) for e in out.events] == [(EventType.BLOCKED, "reach")]


def test_a_move_into_a_wall_is_still_reported_as_a_wall():
    # Out of the zone and into the ground: the wall wins (detail is the move, as before).
    sim = sim_of(strip())
    sim.step([CLAIM_BASE + 0, WAIT])
    sim.step([int(Move.DOWN), WAIT])  # z 1..4
    out = sim.step([int(Move.DOWN), WAIT])
    assert [(e.type, e.detail) for e in out.events] == [(EventType.BLOCKED, str(int(Move.DOWN)))]


def test_automatic_mode_gives_a_crane_only_what_it_can_carry():
    sim = sim_of(strip(NARROW + "\n" + WIDE), auto=True)
    assert list(sim.state.held) == [NOBODY, 0]  # the narrow crane 0 is passed by


# -- planners on the shipped tower-crane scenario ------------------------------------------------


def _play_in_zones(env, policy, seed: int) -> int:
    """Play to the end; at every step each carried component lies in its crane's zone."""
    obs, _ = env.reset(seed=seed)
    sim = env.sim
    while env.agents:
        obs, *_ = env.step(policy(obs))
        st = sim.state
        for c in range(sim.site.n_components):
            if st.status[c] in (Status.IN_TRANSIT, Status.ARRIVED):
                crane = int(st.holder[c])
                assert sim.site.reaches(crane, st.cells[c]), (st.step_count, c, crane)
    assert sim.done, f"not finished in {sim.state.step_count} steps"
    return sim.state.step_count


@pytest.mark.parametrize("planner", ["greedy", "prioritized"])
def test_planners_solve_the_tower_scenario_inside_the_zones(planner):
    scenario = load_scenario("towers-3c")
    assert scenario.cranes == 3 and len(scenario.crane_specs) == 3
    for seed in (0, 1):
        env = multicrane.parallel_env("towers-3c")
        policy = GreedyPolicy(env, seed=seed) if planner == "greedy" else PrioritizedPlanner(env)
        steps = _play_in_zones(env, policy, seed)
        assert steps <= scenario.step_limit
        if planner == "prioritized":
            assert policy.stats["fallbacks"] == 0 and policy.stats["replans"] == 0


def test_tower_scenario_needs_all_its_cranes_and_no_crane_reaches_everything():
    scenario = load_scenario("towers-3c")
    site = Site(scenario)
    for k in range(3):
        assert not all(site.reaches(k, cells) for cells in site.target_cells), k
    for n in (1, 2, 4):
        assert crane_count_problem(scenario, n) is not None
    assert crane_count_problem(scenario, 3) is None
    assert uncarriable(scenario) is None
    # Zones overlap: some target is reached by two cranes.
    both = [t for t, cells in enumerate(site.target_cells)
            if sum(site.reaches(k, cells) for k in range(3)) >= 2]  # fmt: skip
    assert both
