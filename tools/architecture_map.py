"""Writes the module map of docs/architecture.md from the source: each room's modules, in layer
order, with the first line of each module's docstring (run from the repository root)."""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "project"))
from test_architecture import ROOMS  # noqa: E402  (the one list of rooms)

BEGIN, END = "<!-- module map: begin -->", "<!-- module map: end -->"


def job(path: Path) -> str:
    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    first = " ".join(doc.strip().split("\n\n")[0].split())
    return first.replace("|", "\\|")


def name_of(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def table(paths: list[Path]) -> list[str]:
    rows = ["| module | job |", "|---|---|"]
    rows += [f"| `{name_of(p)}` | {job(p)} |" for p in paths]
    return rows


def module_map() -> str:
    lines: list[str] = []
    package = ROOT / "multicrane"
    for room in ROOMS:
        files = sorted((package / room).rglob("*.py"))
        init = package / room / "__init__.py"
        lines += [f"### `{room}/`", "", *table([init] + [f for f in files if f != init]), ""]
    lines += ["### The root: the public face and shared helpers", ""]
    lines += table(sorted(package.glob("*.py"))) + [""]
    lines += ["### Policies (`policies/`, built on `multicrane`)", ""]
    lines += table(sorted((ROOT / "policies").glob("*.py"))) + [""]
    return "\n".join(lines)


def main() -> int:
    page = ROOT / "docs" / "architecture.md"
    text = page.read_text()
    new = re.sub(
        re.escape(BEGIN) + ".*?" + re.escape(END),
        lambda _: f"{BEGIN}\n\n{module_map()}\n{END}",
        text,
        flags=re.S,
    )
    page.write_text(new)
    print(f"wrote the module map of {page.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
