"""``multicrane.reports.scaling`` (``multicrane bench --scaling``): the sites, the fit, one
measurement."""

from __future__ import annotations

import pytest

from multicrane.reports import scaling


def test_every_scaling_site_has_its_component_count():
    for n in (3, 8, 21):  # the larger ones take longer; their counts follow the same formula
        assert scaling.site(n).n_components == n
    nx, ny, storeys = scaling.SHAPES[490]
    per_storey = (nx + 1) * (ny + 1) + nx * (ny + 1) + ny * (nx + 1)
    assert storeys * per_storey == 490
    with pytest.raises(ValueError, match="no scaling site of 7 components"):
        scaling.site(7)


def test_fit_recovers_known_exponents():
    rows = [
        {"components": n, "cranes": k, "cost": 0.5 * n**1.5 * k**0.25}
        for n in (3, 30, 300)
        for k in (1, 4, 16)
    ]
    b, c = scaling.fit_growth(rows, "cost")
    assert b == pytest.approx(1.5) and c == pytest.approx(0.25)
    one_crane = [r for r in rows if r["cranes"] == 1]
    assert scaling.fit_growth(one_crane, "cost") == (pytest.approx(1.5), 0.0)


def test_one_point_is_measured_and_tabled():
    import policies

    row = scaling.measure(3, 2, lambda env, seed: policies.make("greedy", env, seed=seed),
                          steps=20, decisions=10)  # fmt: skip
    assert row["components"] == 3 and row["cranes"] == 2
    assert all(row[k] > 0 for k in ("load_s", "reset_s", "step_ms", "plan_ms", "plan_ms_max"))
    assert row["step_ms_per_crane"] == pytest.approx(row["step_ms"] / 2)
    text = scaling.table([row, {**row, "components": 30, "load_s": 10 * row["load_s"]}])
    assert text.count("\n| 3 | 2 |") == 1 and "`load_s` ~ components^1.00" in text
    assert scaling.grid(full=False) == [(n, k) for n in (3, 21, 121) for k in (1, 4, 16)]
