"""The architecture, checked from the source text (``ast``; no module is imported).

- Layers point one way: ``multicrane`` never imports ``policies`` (the command line,
  ``multicrane.cli`` and ``multicrane.__main__``, is the top floor and may).
- No import cycle between modules (an import under ``TYPE_CHECKING`` counts: it is still a
  dependency a reader must follow). A package's ``__init__`` importing its own submodules to
  re-export them is not a cycle.
- Every module opens with a docstring saying its one job, and none is much over 400 lines.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("multicrane", "policies")
MAX_LINES = 450  # "none much over 400 lines"


def module_files(root: Path = ROOT) -> dict[str, Path]:
    """Dotted module name -> file, for every module of the two packages."""
    mods = {}
    for pkg in PACKAGES:
        for f in sorted((root / pkg).rglob("*.py")):
            parts = f.relative_to(root).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            mods[name] = f
    return mods


def _targets(current: str, is_package: bool, node: ast.AST) -> list[str]:
    """The dotted names an import statement may refer to (a module or a name in one)."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    assert isinstance(node, ast.ImportFrom)
    base = node.module or ""
    if node.level:
        parts = current.split(".")
        keep = len(parts) - node.level + (1 if is_package else 0)
        base = ".".join(parts[:keep] + ([base] if base else []))
    return [base] + [f"{base}.{a.name}" for a in node.names]


def import_graph(mods: dict[str, Path]) -> dict[str, set[str]]:
    """Module -> the modules of the two packages it imports."""
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for name, path in mods.items():
        is_package = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if not isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            for target in _targets(name, is_package, node):
                while target and target not in mods:
                    target = target.rpartition(".")[0]
                if target and target != name:
                    if is_package and target.startswith(name + "."):
                        continue  # a package re-exporting its own submodules
                    graph[name].add(target)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    component.append(top)
                    if top == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def is_command_line(module: str) -> bool:
    return module in ("multicrane.cli", "multicrane.__main__") or module.startswith(
        "multicrane.cli."
    )


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    return sorted(
        f"{m} -> {d}"
        for m, deps in graph.items()
        if m.startswith("multicrane") and not is_command_line(m)
        for d in deps
        if d == "policies" or d.startswith("policies.")
    )


MODULES = module_files()
GRAPH = import_graph(MODULES)


def test_multicrane_never_imports_policies():
    assert upward_imports(GRAPH) == []


def test_no_import_cycles():
    assert cycles(GRAPH) == []


@pytest.mark.parametrize("name", sorted(MODULES))
def test_module_says_its_job_and_is_small(name):
    path = MODULES[name]
    text = path.read_text()
    doc = ast.get_docstring(ast.parse(text))
    assert doc and doc.strip().splitlines()[0].strip(), f"{path}: no module docstring"
    n = len(text.splitlines())
    assert n <= MAX_LINES, f"{path}: {n} lines; a module much over 400 lines does two jobs"


# -- the checker itself must be able to fail -------------------------------------------------


def test_checker_finds_a_cycle_and_an_upward_import(tmp_path):
    (tmp_path / "multicrane").mkdir()
    (tmp_path / "policies").mkdir()
    (tmp_path / "multicrane" / "__init__.py").write_text('"""p."""\n')
    (tmp_path / "multicrane" / "a.py").write_text('"""a."""\nfrom multicrane import b\n')
    (tmp_path / "multicrane" / "b.py").write_text(
        '"""b."""\nfrom typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from . import a\n'
    )
    (tmp_path / "multicrane" / "cli.py").write_text('"""c."""\nimport policies.p\n')
    (tmp_path / "multicrane" / "low.py").write_text('"""l."""\nfrom policies.p import x\n')
    (tmp_path / "policies" / "__init__.py").write_text('"""q."""\n')
    (tmp_path / "policies" / "p.py").write_text('"""p."""\nimport multicrane.a\nx = 1\n')
    graph = import_graph(module_files(tmp_path))
    assert cycles(graph) == [["multicrane.a", "multicrane.b"]]
    assert upward_imports(graph) == ["multicrane.low -> policies.p"]
