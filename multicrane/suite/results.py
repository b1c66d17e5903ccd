"""Results files of the suite: read and write them, and their gaps to the bound and best-known.

A results file is the JSON of ``multicrane.suite.play.play_track``'s dict (gzip when the name
ends in ``.gz``). The gap of a makespan ``m`` to a reference ``r`` (the instance's lower
bound, or its best-known makespan) is ``100 (m - r) / r`` percent; a track's gap is the mean
over its instances, counted only when every instance was completed (else ``None``).
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path
from typing import Any

from multicrane.files import write_atomic
from multicrane.suite.manifest import SuiteError
from multicrane.tables import text_table


def write_results(path: str | Path, results: dict[str, Any]) -> Path:
    """Write a results file (compact JSON; gzip when the name ends in ``.gz``)."""
    path = Path(path)
    text = json.dumps(results, separators=(",", ":")) + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, gzip.compress(text.encode(), mtime=0) if path.suffix == ".gz" else text)
    return path


def read_results(path: str | Path) -> dict[str, Any]:
    """A results file's dict (SuiteError naming the file if it cannot be read)."""
    path = Path(path)
    try:
        raw = path.read_bytes()
        if path.suffix == ".gz":
            raw = gzip.decompress(raw)
        data = json.loads(raw.decode("utf-8"))
    except (OSError, EOFError, ValueError) as exc:
        raise SuiteError(f"{path}: cannot read results file: {exc}") from None
    if not isinstance(data, dict) or not isinstance(data.get("instances"), list):
        raise SuiteError(f"{path}: not a suite results file")
    return data


def gap(makespan: int | None, reference: int | None) -> float | None:
    """``100 (makespan - reference) / reference`` (None when either is missing)."""
    if makespan is None or not reference:
        return None
    return 100.0 * (makespan - reference) / reference


def mean(values: list[float | None]) -> float | None:
    """The mean, or None when a value is missing (or there is none)."""
    if not values or any(v is None for v in values):
        return None
    return sum(values) / len(values)


def pct(value: float | None) -> str:
    return "-" if value is None else f"{value:+.1f} %"


def track_summary(entries: list[dict[str, Any]]) -> dict[str, Any]:
    """A track's totals: instances, completed, mean makespan and mean gaps, seconds."""
    spans = [e["makespan"] for e in entries]
    done = [m for m in spans if m is not None]
    return {
        "instances": len(entries),
        "completed": len(done),
        "makespan_mean": sum(done) / len(done) if done else None,
        "gap_bound": mean([gap(e["makespan"], e.get("bound")) for e in entries]),
        "gap_best": mean([gap(e["makespan"], e.get("best_known")) for e in entries]),
        "seconds": round(sum(e.get("seconds", 0.0) for e in entries), 1),
    }


def results_table(results: dict[str, Any]) -> str:
    """Per instance and for the track: makespan, bound, best-known and the two gaps."""
    head = ["instance", "makespan", "bound", "gap to bound", "best known", "gap to best",
            "seconds"]  # fmt: skip
    rows = []
    for e in results["instances"]:
        rows.append([
            e["id"], _int(e["makespan"]), _int(e.get("bound")),
            pct(gap(e["makespan"], e.get("bound"))), _int(e.get("best_known")),
            pct(gap(e["makespan"], e.get("best_known"))), f"{e.get('seconds', 0.0):.1f}",
        ])  # fmt: skip
    s = track_summary(results["instances"])
    mean_span = "-" if s["makespan_mean"] is None else f"{s['makespan_mean']:.1f}"
    rows.append([f"{results['track']} ({s['completed']}/{s['instances']} done)", mean_span, "",
                 pct(s["gap_bound"]), "", pct(s["gap_best"]), f"{s['seconds']:.1f}"])  # fmt: skip
    return text_table(head, rows)


def _int(value: int | None) -> str:
    return "-" if value is None else str(value)
