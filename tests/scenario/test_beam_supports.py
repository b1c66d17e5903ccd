"""The loader's rule for beams on beams (the kind table: a beam rests on columns or beams).

Each case edits the secondary beam ``s`` of the beams-on-beams site of
``tests/sim/test_beams_on_beams.py`` (two primary beams on four columns, ``s`` resting on
both) and expects it to load with these supports, or to be refused with a message naming the
key and the problem.
"""

from __future__ import annotations

import pytest
from test_beams_on_beams import B1, B2, C2, S, site

from multicrane.core.schema import ScenarioError
from multicrane.scenario.loader import parse_scenario

TARGET = "target = [[7, 3, 3], [7, 5, 3]]"
SUPPORTS = 'initial = [[3, 5, 1], [3, 7, 1]]\nsupports = ["b1", "b2"]'


def edit(target: str = TARGET, supports: str = '["b1", "b2"]') -> str:
    """The site with the secondary beam's target and supports replaced."""
    text = site()
    assert text.count(TARGET) == 1 and text.count(SUPPORTS) == 1
    return text.replace(TARGET, target).replace(SUPPORTS, SUPPORTS.replace('["b1", "b2"]',
                                                                          supports))  # fmt: skip


@pytest.mark.parametrize(
    ("target", "supports", "expected"),
    [
        (TARGET, '["b1", "b2"]', (B1, B2)),  # framing into two beams
        (TARGET, '["b1"]', (B1,)),  # one support is enough for the named rule
        # beside a beam and on a column's top at once: a beam rests on both kinds
        ("target = [[7, 3, 3], [9, 3, 3]]", '["b1", "c2"]', (B1, C2)),
    ],
)
def test_a_beam_on_beams_loads(target, supports, expected):
    s = parse_scenario(edit(target, supports), source="beams.toml")
    assert s.components[S].supports == expected


@pytest.mark.parametrize(
    ("target", "supports", "words"),
    [
        (TARGET, '["s", "b1"]', "'s' is this beam itself, not a column or beam it rests on"),
        (TARGET, '["b1", "c1"]', "the target of 'c1' does not touch this beam"),
        ("target = [[7, 2, 2], [7, 4, 2]]", '["b1"]',
         "the target of 'b1' lies above this beam: it rests on what is under or beside it"),
    ],
)  # fmt: skip
def test_a_beam_on_beams_is_refused_where_it_breaks_the_rule(target, supports, words):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(edit(target, supports), source="beams.toml")
    assert "components[6].supports" in str(err.value) and words in str(err.value)


def test_beams_resting_on_each_other_form_a_cycle():
    text = site().replace('supports = ["c1", "c2"]', 'supports = ["c1", "c2", "s"]')
    with pytest.raises(ScenarioError, match=r"the supports form a cycle \('b1' -> 's' -> 'b1'\)"):
        parse_scenario(text, source="beams.toml")
