"""Plot a training run's learning curve (makespan of the evaluation episodes) as a PNG.

    python tools/marl_curve.py RUN_DIR OUT.png [--line LABEL=VALUE ...]

Reads RUN_DIR/result.json (or, for a run still going, its checkpoint's progress) and draws
the mean makespan of the greedy evaluation episodes against crane decisions trained, with
horizontal reference lines (e.g. the prioritized planner and the lower bound). Needs
matplotlib (the ``bench`` extra).
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
    p.add_argument("run_dir", type=Path)
    p.add_argument("out", type=Path)
    p.add_argument("--line", action="append", default=[], metavar="LABEL=VALUE")
    p.add_argument("--title", default=None)
    args = p.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    points = curve(args.run_dir)
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.plot([q["step"] for q in points], [q["steps_mean"] for q in points], marker="o",
            label="set policy (greedy evaluation)")  # fmt: skip
    for i, item in enumerate(args.line):
        label, _, value = item.partition("=")
        ax.axhline(float(value), linestyle="--", linewidth=1, color=f"C{i + 1}",
                   label=f"{label} ({value})")  # fmt: skip
    ax.set_xlabel("crane decisions trained (rows)")
    ax.set_ylabel("mean makespan (simulated steps)")
    ax.set_title(args.title or args.run_dir.name)
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out} ({len(points)} points)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
