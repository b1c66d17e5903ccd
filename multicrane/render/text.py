"""Text rendering: the site layer by layer, for ``render_mode="ansi"``."""

from __future__ import annotations

from typing import TYPE_CHECKING

from multicrane.core.codes import Status

if TYPE_CHECKING:
    from multicrane.sim.simulator import Simulator

# One letter per component state; upper case marks a component held by a crane.
STATE_CHARS = {
    Status.INITIAL: "i",
    Status.IN_TRANSIT: "t",
    Status.ARRIVED: "a",
    Status.ASSEMBLED: "b",
}
LEGEND = (
    "legend: # obstacle, + free target, i initial, t in transit, a arrived, b built "
    "(upper case: held by a crane), F foundation (layer 1), . empty; y grows upwards"
)


def render_ansi(sim: Simulator) -> str:
    """Every non-empty layer from the top down; x grows to the right, y upwards."""
    X, Y, H = sim.scenario.size
    grid = sim.state.occ.reshape(sim.site.shape)
    target_at = sim.site.target_at.reshape(sim.site.shape)
    foundations = set(sim.scenario.foundations)
    lines = [
        f"step {sim.state.step_count}: {sim.state.n_assembled}/{sim.site.n_components} assembled; "
        + ", ".join(_crane_text(sim, c) for c in range(sim.n_cranes)),
        LEGEND,
    ]
    for z in range(H, 0, -1):
        rows = []
        for y in range(Y - 1, -1, -1):
            row = []
            for x in range(X):
                v = int(grid[x + 1, y + 1, z])
                t = int(target_at[x + 1, y + 1, z])
                if v == -1:
                    ch = "#"
                elif v > 0:
                    comp = v - 1
                    ch = STATE_CHARS[Status(int(sim.state.status[comp]))]
                    if sim.state.holder[comp] >= 0:
                        ch = ch.upper()
                elif t >= 0 and sim.state.filled_by[t] < 0:
                    ch = "+"
                elif z == 1 and (x, y) in foundations:
                    ch = "F"
                else:
                    ch = "."
                row.append(ch)
            rows.append("".join(row))
        if any(set(r) - {"."} for r in rows):
            lines.append(f"z = {z}")
            lines.extend(rows)
    return "\n".join(lines)


def _crane_text(sim: Simulator, crane: int) -> str:
    comp = sim.state.held[crane]
    if sim.state.pass_over[crane]:
        return f"crane_{crane}: pass-over"
    if comp < 0:
        return f"crane_{crane}: idle"
    cid = sim.scenario.components[comp].id
    state = Status(int(sim.state.status[comp])).name.lower()
    return f"crane_{crane}: {cid} ({state}, {int(sim.state.moves[comp])} moves)"
