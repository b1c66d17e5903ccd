"""The leaderboard: best-known makespans from verified results files, and the page that shows them.

``collect(manifest, paths)`` reads and verifies (``multicrane.suite.verify``) every results
file; a file that fails stops the page with the error (naming the file and the instance).
``best_known(collected)`` is, per instance, the smallest verified makespan and where its
record is kept (file, policy; the first file in name order on ties); ``write_best`` keeps it in
the version's ``best.json`` (read by ``read_best`` for the gaps ``suite evaluate`` prints).
``leaderboard(...)`` is the markdown page: per track, the entries, then per instance its bound
and best-known. Each entry has a kind (``entry_kind``): ``planner`` (a name in ``first``, the
project's planners), ``learned`` (results that carry a training run's ``training`` block,
``multicrane.suite.play.training_block``, or a planner given a learned order, ``scorer=``),
``search`` (the large-neighbourhood search of ``suite improve``, ``SEARCH``) or
``submitted``; the entries are ranked in that order of kinds, each kind by gap to the bound.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from multicrane.episodes.policy_spec import spec_name, spec_options
from multicrane.files import write_atomic
from multicrane.suite.manifest import Manifest, SuiteError
from multicrane.suite.results import gap, mean, pct, read_results, track_summary
from multicrane.suite.tracks import size_of
from multicrane.suite.verify import verify
from multicrane.tables import markdown_table

BEST = "best.json"
RESULTS_DIR = "results"
TARGETS = {"small": 5.0, "medium": 10.0}  # issue 35: mean gap best-known vs bound (percent)
SEARCH = "lns"  # the policy name of the results ``suite improve`` writes (multicrane.suite.lns)
KINDS = ("planner", "learned", "search", "submitted")  # the page's order of entries


def results_files(manifest: Manifest) -> list[Path]:
    """The results files kept with the version (``results/*.json`` and ``*.json.gz``)."""
    folder = manifest.folder / RESULTS_DIR
    return sorted([*folder.glob("*.json"), *folder.glob("*.json.gz")])


def collect(manifest: Manifest, paths: list[Path]) -> list[dict[str, Any]]:
    """Each file's results, verified (SuiteError naming the file and the instance if not)."""
    out = []
    for path in paths:
        results = read_results(path)
        try:
            verify(results, manifest)
        except SuiteError as exc:
            raise SuiteError(f"{path}: {exc}") from None
        out.append({"path": path, "results": results})
    return out


def best_known(collected: list[dict[str, Any]], folder: Path) -> dict[str, dict[str, Any]]:
    """Instance id -> its best verified makespan, the policy and the file (relative to
    ``folder``) that holds its record."""
    best: dict[str, dict[str, Any]] = {}
    for item in collected:
        results = item["results"]
        for e in results["instances"]:
            m = e["makespan"]
            if m is None or (e["id"] in best and best[e["id"]]["makespan"] <= m):
                continue
            best[e["id"]] = {"makespan": m, "policy": results["policy"],
                             "decisions": results["decisions"],
                             "results": _relative(item["path"], folder)}  # fmt: skip
    return best


def _relative(path: Path, folder: Path) -> str:
    try:
        return Path(path).resolve().relative_to(folder.resolve()).as_posix()
    except ValueError:
        return str(path)


def write_best(manifest: Manifest, best: dict[str, dict[str, Any]]) -> Path:
    """Keep the best-known makespans in the version's best.json (manifest order)."""
    order = {i.id: n for n, i in enumerate(manifest.instances)}
    data = {"version": manifest.version, "manifest_sha256": manifest.sha256,
            "instances": {k: best[k] for k in sorted(best, key=order.__getitem__)}}  # fmt: skip
    path = manifest.folder / BEST
    write_atomic(path, json.dumps(data, indent=1) + "\n")
    return path


def read_best(manifest: Manifest) -> dict[str, int]:
    """Instance id -> best-known makespan (empty without a best.json for this manifest)."""
    return {k: v["makespan"] for k, v in read_best_entries(manifest).items()}


def read_best_entries(manifest: Manifest) -> dict[str, dict[str, Any]]:
    """Instance id -> its best.json entry: makespan, policy, decisions and the results file
    (relative to the version's folder) that holds its record (empty without a best.json
    for this manifest)."""
    path = manifest.folder / BEST
    if not path.is_file():
        return {}
    data = json.loads(path.read_text())
    if data.get("manifest_sha256") != manifest.sha256:
        return {}
    return data["instances"]


def leaderboard(manifest: Manifest, collected: list[dict[str, Any]],
                best: dict[str, dict[str, Any]], bounds: dict[str, dict[str, Any]],
                first: tuple[str, ...] = (), command: str = "") -> str:  # fmt: skip
    """The leaderboard page (markdown)."""
    lines = [
        "# multicrane-bench leaderboard", "",
        f"Written by `{command or 'multicrane suite page'}` from the verified results files "
        f"of `scenarios/suite/{manifest.version}/{RESULTS_DIR}/` (suite {manifest.version}, "
        f"manifest sha256 `{manifest.sha256[:16]}...`); do not edit. How the instances, "
        "bounds and best-known plans are made, and how to submit: [suite.md](suite.md).", "",
        "Gaps are `100 (makespan - reference) / reference`, averaged over a track's "
        "instances (`-` when an entry did not complete every instance); the reference is "
        "the CP-SAT lower bound of today or the best-known makespan. `seconds`: the wall "
        "time of the whole track on the machine that played it (not comparable across "
        "machines or loads).", "",
        "## Best known against the bound", "",
        *_summary(manifest, best, bounds), "",
    ]  # fmt: skip
    for track in manifest.tracks():
        lines += [f"## Track `{track}`", ""]
        lines += _entries(manifest, track, collected, best, bounds, first) + [""]
        lines += _instances(manifest, track, best, bounds) + [""]
    return "\n".join(lines)


def _entry_gaps(entries: list[dict], best: dict, bounds: dict) -> dict[str, Any]:
    filled = [{**e, "bound": bounds.get(e["id"], {}).get("bound"),
               "best_known": best.get(e["id"], {}).get("makespan")} for e in entries]  # fmt: skip
    return track_summary(filled)


def _summary(manifest: Manifest, best: dict, bounds: dict) -> list[str]:
    head = ["track", "instances", "bounds (optimal relaxation)", "best known",
            "mean gap best known to bound", "target"]  # fmt: skip
    rows = []
    for track in manifest.tracks():
        ids = [i.id for i in manifest.track(track)]
        have = [bounds[i] for i in ids if i in bounds]
        optimal = sum(b["status"] == "optimal" for b in have)
        gaps = [gap(best.get(i, {}).get("makespan"), bounds.get(i, {}).get("bound")) for i in ids]
        target = TARGETS.get(size_of(track))
        rows.append([f"`{track}`", str(len(ids)), f"{len(have)} ({optimal})",
                     str(sum(i in best for i in ids)), pct(mean(gaps)),
                     "" if target is None else f"<= {target:.0f} %"])  # fmt: skip
    return markdown_table(head, rows)


def _entries(manifest: Manifest, track: str, collected: list, best: dict, bounds: dict,
             first: tuple[str, ...]) -> list[str]:  # fmt: skip
    rows = []
    for item in collected:
        results = item["results"]
        if results["track"] != track:
            continue
        s = _entry_gaps(results["instances"], best, bounds)
        kind = entry_kind(results, first)
        rank = (KINDS.index(kind), s["gap_bound"] is None, s["gap_bound"] or 0.0)
        span = "-" if s["makespan_mean"] is None else f"{s['makespan_mean']:.1f}"
        rows.append((rank, [
            f"`{results['policy']}`", results["decisions"], f"{s['completed']}/{s['instances']}",
            span, pct(s["gap_bound"]), pct(s["gap_best"]), f"{s['seconds']:.0f}",
            f"`{_relative(item['path'], manifest.folder)}`", kind,
        ]))  # fmt: skip
    if not rows:
        return ["No verified results on this track yet."]
    head = ["policy", "decisions", "completed", "mean makespan", "gap to bound",
            "gap to best known", "seconds", "results", "kind"]  # fmt: skip
    ranked = [row for _, row in sorted(rows, key=lambda r: r[0])]
    return markdown_table(head, ranked, align="llrrrrrll")


def entry_kind(results: dict[str, Any], planners: tuple[str, ...]) -> str:
    """What made a results file's entry, one of ``KINDS`` (see the module doc); a planner
    given with options (``lookahead:candidates=20``) is a planner, but one given a learned
    list order (``prioritized:rank=chain,scorer=order-es21-s0``) is learned."""
    if "training" in results or "scorer" in spec_options(results["policy"]):
        return "learned"
    if spec_name(results["policy"]) in planners:
        return "planner"
    return "search" if results["policy"] == SEARCH else "submitted"


def _instances(manifest: Manifest, track: str, best: dict, bounds: dict) -> list[str]:
    head = ["instance", "components", "cranes", "events", "bound (status, s)", "best known",
            "by", "gap"]  # fmt: skip
    rows = []
    for i in manifest.track(track):
        b, k = bounds.get(i.id), best.get(i.id)
        rows.append([
            i.id, str(i.components), str(i.cranes), i.events,
            "-" if b is None else f"{b['bound']} ({b['status']}, {b['wall_s']:.0f})",
            "-" if k is None else str(k["makespan"]), "" if k is None else f"`{k['policy']}`",
            pct(gap(k and k["makespan"], b and b["bound"])),
        ])  # fmt: skip
    return markdown_table(head, rows, align="lrrlrrlr")
