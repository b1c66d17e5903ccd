"""The scenario's ``[events]`` table: read strictly into an ``EventSpec``, and written back.

Every key is optional (an empty table is a site with the events machinery on and nothing
happening); see ``scenarios/README.md`` for the schema and ``multicrane.sim.events`` for the
meaning. Each problem is a ``ScenarioError`` naming the file, the key and the value.
``events_lines`` writes the table (``multicrane.scenario.writer``) so that it reads back equal.
"""

from __future__ import annotations

from multicrane.core.schema import ScenarioError
from multicrane.scenario.toml_table import TomlTable
from multicrane.sim.events import EventSpec, FixedClosure

MAX_STEP = 1_000_000  # no time in the table may exceed this


def parse_events(t: TomlTable, size: tuple[int, int, int], ids: list[str]) -> EventSpec:
    """The ``[events]`` table of a scenario with this site ``size`` and component ``ids``."""
    arrivals = _arrivals(t, ids)
    spec = dict(
        arrivals=arrivals,
        late_fraction=_fraction(t, "late_fraction"),
        delay=_range(t, "delay", 0, (0, 0)),
        breakdown_rate=_fraction(t, "breakdown_rate"),
        breakdown_duration=_range(t, "breakdown_duration", 1, (1, 1)),
        closures=tuple(_closure(c, size) for c in _closure_tables(t)),
        closure_rate=_fraction(t, "closure_rate"),
        closure_size=_range(t, "closure_size", 1, (1, 1)),
        closure_duration=_range(t, "closure_duration", 1, (1, 1)),
    )
    t.finish()
    return EventSpec(**spec)


def _fraction(t: TomlTable, name: str) -> float:
    v = t.get(name, float, 0.0)
    if not 0.0 <= v <= 1.0:
        raise t.fail(name, v, "must lie in [0, 1]")
    return v


def _range(t: TomlTable, name: str, low: int, default: tuple[int, int]) -> tuple[int, int]:
    v = t.ints(name, 2, default)
    if not low <= v[0] <= v[1] <= MAX_STEP:
        raise t.fail(name, list(v), f"must be [lo, hi] with {low} <= lo <= hi <= {MAX_STEP}")
    return (v[0], v[1])


def _arrivals(t: TomlTable, ids: list[str]) -> tuple[int, ...]:
    """``arrivals = { id = step, ... }``: the due step of the components named (others 0)."""
    table = t.table("arrivals", required=False)
    if table is None:
        return ()
    out = [0] * len(ids)
    for name in list(table.data):
        if name not in ids:
            raise table.fail(name, table.data[name], "no component has this id")
        step = table.get(name, int)
        if not 0 <= step <= MAX_STEP:
            raise table.fail(name, step, f"must lie in 0..{MAX_STEP}")
        out[ids.index(name)] = step
    table.finish()
    return tuple(out)


def _closure_tables(t: TomlTable) -> list[TomlTable]:
    return t.tables("closures") if t.has("closures") else []


def _closure(c: TomlTable, size: tuple[int, int, int]) -> FixedClosure:
    """``{ min = [x, y, z], max = [x, y, z], start = s, end = e }``, inclusive corners."""
    lo, hi = c.ints("min", 3), c.ints("max", 3)
    limits = (size[0] - 1, size[1] - 1, size[2])
    for name, cell in (("min", lo), ("max", hi)):
        if not all(low <= v <= top for v, low, top in zip(cell, (0, 0, 1), limits, strict=True)):
            raise c.fail(name, list(cell), f"lies outside the site (size {list(size)}, z >= 1)")
    if any(a > b for a, b in zip(lo, hi, strict=True)):
        raise c.fail("max", list(hi), f"is below min = {list(lo)} on some axis")
    start, end = c.get("start", int), c.get("end", int)
    if not 0 <= start < end <= MAX_STEP:
        raise c.fail("end", end, f"must be > start = {start} (and start >= 0, end <= {MAX_STEP})")
    c.finish()
    return FixedClosure((lo, hi), start, end)


def events_lines(spec: EventSpec, ids: tuple[str, ...]) -> list[str]:
    """The ``[events]`` table of ``spec`` as TOML lines (every key written)."""

    def pair(v: tuple[int, int]) -> str:
        return f"[{int(v[0])}, {int(v[1])}]"

    out = [
        "[events]",
        f"late_fraction = {float(spec.late_fraction)!r}",
        f"delay = {pair(spec.delay)}",
        f"breakdown_rate = {float(spec.breakdown_rate)!r}",
        f"breakdown_duration = {pair(spec.breakdown_duration)}",
        f"closure_rate = {float(spec.closure_rate)!r}",
        f"closure_size = {pair(spec.closure_size)}",
        f"closure_duration = {pair(spec.closure_duration)}",
    ]
    if spec.arrivals:
        named = ", ".join(f'"{i}" = {int(a)}' for i, a in zip(ids, spec.arrivals, strict=True))
        out.append(f"arrivals = {{ {named} }}")
    for c in spec.closures:
        lo, hi = (", ".join(str(int(v)) for v in cell) for cell in c.box)
        out += ["", "[[events.closures]]", f"min = [{lo}]", f"max = [{hi}]",
                f"start = {int(c.start)}", f"end = {int(c.end)}"]  # fmt: skip
    return out + [""]


__all__ = ["events_lines", "parse_events", "ScenarioError"]
