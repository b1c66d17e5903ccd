"""The docs stand alone: every relative link resolves, and nothing cites a file outside the repo.

Checked over every markdown file of the repository (README.md, docs/, scenarios/README.md, …):

- each relative link or image, ``[text](path)`` or ``[text](path#anchor)``, names a file or
  folder that exists, and an anchor names a heading of the linked markdown file (GitHub's
  heading ids);
- each markdown file name quoted in code spans (`` `name.md` ``) exists somewhere in the repo.

And over the markdown files and the Python sources: no citation of the notes that were
never part of the repository (the benchmark specification now lives in docs/paper-spec.md).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SKIP_DIRS = {"node_modules", "build", "dist", "runs", "__pycache__"}

# Files that were cited in the past but are not in the repository (kept out of this file's
# own text by joining the pieces).
NOT_IN_REPO = tuple(
    "".join(parts)
    for parts in (
        ("paper-", "benchmark.md"),
        ("stack-", "notes.md"),
        ("design-", "notes.md"),
        ("marl-", "notes.md"),
        ("shared/", "reference"),
        ("../", "shared"),
    )
)

LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
CODE_MD = re.compile(r"`([\w./-]+\.md)`")
FENCE = re.compile(r"^(```|~~~).*?^\1", re.S | re.M)
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$", re.M)


def repo_files(*suffixes: str) -> list[Path]:
    out = []
    for path in ROOT.rglob("*"):
        rel = path.relative_to(ROOT).parts
        if any(p.startswith(".") or p in SKIP_DIRS or p.endswith(".egg-info") for p in rel):
            continue
        if path.is_file() and path.suffix in suffixes:
            out.append(path)
    return sorted(out)


MARKDOWN = repo_files(".md")
SOURCES = repo_files(".md", ".py", ".toml", ".sh")


def prose(path: Path) -> str:
    """The file's text without fenced code blocks (links in examples are not links)."""
    return FENCE.sub("", path.read_text(encoding="utf-8"))


def slug(heading: str) -> str:
    """GitHub's id for a heading: lower case, markup and punctuation dropped, spaces -> '-'."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link keeps its text
    text = re.sub(r"[`*_]", "", text).strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    for heading in HEADING.findall(prose(path)):
        base = slug(heading)
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return out


def rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def test_the_repository_has_markdown():
    names = {rel(p) for p in MARKDOWN}
    assert {"README.md", "docs/paper-spec.md", "scenarios/README.md"} <= names


@pytest.mark.parametrize("path", MARKDOWN, ids=rel)
def test_relative_links_resolve(path):
    broken = []
    for target in LINK.findall(prose(path)):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):  # http:, https:, mailto:, …
            continue
        file_part, _, anchor = target.partition("#")
        linked = (path.parent / file_part).resolve() if file_part else path
        if not linked.exists():
            broken.append(f"{target}: no such file")
            continue
        try:
            linked.relative_to(ROOT)
        except ValueError:
            broken.append(f"{target}: outside the repository")
            continue
        if anchor and linked.suffix == ".md" and anchor not in anchors(linked):
            broken.append(f"{target}: no heading with id {anchor!r} in {rel(linked)}")
    assert not broken, f"{rel(path)}: " + "; ".join(broken)


@pytest.mark.parametrize("path", MARKDOWN, ids=rel)
def test_quoted_markdown_files_exist(path):
    known = {p.name for p in MARKDOWN} | {rel(p) for p in MARKDOWN}
    missing = sorted({name for name in CODE_MD.findall(prose(path)) if name not in known})
    assert not missing, f"{rel(path)} names markdown files not in the repository: {missing}"


def test_nothing_cites_files_outside_the_repository():
    me = Path(__file__).resolve()
    hits = []
    for path in SOURCES:
        if path.resolve() == me:
            continue
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for name in NOT_IN_REPO:
                if name in line:
                    hits.append(f"{rel(path)}:{n}: {name}")
    assert not hits, "cite docs/paper-spec.md (or state the fact) instead:\n" + "\n".join(hits)


def module_name(path: Path) -> str:
    return ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")


def test_architecture_picture_stacks_the_rooms_in_layer_order():
    """The picture of docs/architecture.md lists the rooms top floor first, as ROOMS orders them."""
    from test_architecture import ROOMS

    page = (ROOT / "docs" / "architecture.md").read_text()
    picture = page.split("```")[1].splitlines()
    drawn = [line.split()[0] for line in picture if line.strip() and line.split()[0] in ROOMS]
    assert drawn == list(reversed(ROOMS))


def test_architecture_module_map_is_the_one_the_source_writes():
    from conftest import load_tool

    amap = load_tool("architecture_map")
    page = (ROOT / "docs" / "architecture.md").read_text()
    assert f"{amap.BEGIN}\n\n{amap.module_map()}\n{amap.END}" in page, (
        "the module map is out of date: run python3 tools/architecture_map.py"
    )


def test_architecture_page_maps_every_module():
    """docs/architecture.md lists every module of both packages (its module map)."""
    page = (ROOT / "docs" / "architecture.md").read_text()
    modules = [
        module_name(f) for pkg in ("multicrane", "policies") for f in (ROOT / pkg).rglob("*.py")
    ]
    missing = sorted(m for m in modules if f"`{m}`" not in page)
    assert missing == [], f"docs/architecture.md does not map: {missing}"
