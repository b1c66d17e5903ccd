"""Plot training runs' learning curves (makespan of the evaluation episodes) as a PNG.

    python tools/marl_curve.py RUN_DIR [RUN_DIR ...] OUT.png [--line LABEL=VALUE ...]

Reads each RUN_DIR/result.json (or, for a run still going, its checkpoint's progress) and draws
the mean makespan of the greedy evaluation episodes against crane decisions trained, with
horizontal reference lines (e.g. the prioritized planner and the lower bound). With several
runs (training seeds of one setting, evaluated at the same points) each is a thin line and
their mean a thick one, with the Student-t 95 % interval over seeds as a band
(``multicrane.stats.ci95``). A point where a run did not finish every evaluation episode
(its makespan is then the step limit) is left out of the mean and drawn as a red cross at
the top of the plot. Needs matplotlib (the ``bench`` extra).
"""

from __future__ import annotations

import argparse
import json
import pickle
from pathlib import Path


def curve(run_dir: Path) -> list[dict]:
    result = run_dir / "result.json"
    if result.exists():
        return json.loads(result.read_text())["curve"]
    with open(run_dir / "checkpoint" / "state.pkl", "rb") as f:  # our own checkpoint
        return pickle.load(f)["progress"]["curve"]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("paths", type=Path, nargs="+", metavar="RUN_DIR ... OUT.png")
    p.add_argument("--line", action="append", default=[], metavar="LABEL=VALUE")
    p.add_argument("--title", default=None)
    args = p.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    *runs, out = args.paths
    if not runs:
        p.error("give at least one RUN_DIR and the OUT.png")
    curves = [curve(r) for r in runs]
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    if len(curves) == 1:
        points = curves[0]
        ax.plot([q["step"] for q in points], [q["steps_mean"] for q in points], marker="o",
                label="set policy (greedy evaluation)")  # fmt: skip
    else:
        from multicrane.stats import ci95

        n = min(len(c) for c in curves)  # the points every run reached
        steps = [q["step"] for q in curves[0][:n]]
        finished = [[q.get("success_rate", 1.0) >= 1.0 for q in c[:n]] for c in curves]
        top = max(
            q["steps_mean"]
            for c, ok in zip(curves, finished, strict=True)
            for q, f in zip(c[:n], ok, strict=True)
            if f
        )
        for c, ok in zip(curves, finished, strict=True):
            ax.plot(steps, [q["steps_mean"] if f else None for q, f in zip(c[:n], ok, strict=True)],
                    color="C0", alpha=0.3, linewidth=1)  # fmt: skip
        stalls = [(steps[i], top * 1.03) for ok in finished for i, f in enumerate(ok) if not f]
        if stalls:
            ax.scatter([x for x, _ in stalls], [y for _, y in stalls], marker="x", color="red",
                       zorder=3, label="a seed that did not finish every episode")  # fmt: skip
        columns = [
            [c[i]["steps_mean"] for c, ok in zip(curves, finished, strict=True) if ok[i]]
            for i in range(n)
        ]
        mean = [sum(col) / len(col) for col in columns]
        band = [ci95(col) or (m, m) for col, m in zip(columns, mean, strict=True)]
        ax.plot(steps, mean, color="C0", marker="o", linewidth=2,
                label=f"set policy, mean of {len(curves)} seeds (greedy evaluation)")  # fmt: skip
        ax.fill_between(steps, [b[0] for b in band], [b[1] for b in band], color="C0",
                        alpha=0.15, label="95 % interval over seeds")  # fmt: skip
        points = curves[0][:n]
    for i, item in enumerate(args.line):
        label, _, value = item.partition("=")
        ax.axhline(float(value), linestyle="--", linewidth=1, color=f"C{i + 1}",
                   label=f"{label} ({value})")  # fmt: skip
    ax.set_xlabel("crane decisions trained (rows)")
    ax.set_ylabel("mean makespan (simulated steps)")
    ax.set_title(args.title or runs[0].name)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out} ({len(curves)} run(s), {len(points)} points)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
