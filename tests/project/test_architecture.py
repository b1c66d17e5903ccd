"""The architecture, checked from the source text (``ast``; no module is imported).

- Layers point one way: ``multicrane`` never imports ``policies`` (the command line,
  ``multicrane.cli`` and ``multicrane.__main__``, is the top floor and may).
- No import cycle between modules (an import under ``TYPE_CHECKING`` counts: it is still a
  dependency a reader must follow). A package's ``__init__`` importing its own submodules to
  re-export them is not a cycle.
- The library's folders are its rooms, ordered by layer (``ROOMS``, lowest first): no module
  imports a module of a higher room. The root package keeps the public face and a few shared
  helpers that import nothing of ours; every room's ``__init__`` says what it may import.
- Every module opens with a docstring saying its one job; none is over 400 lines and no
  function is over 80.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("multicrane", "policies")
MAX_LINES = 400
MAX_FUNCTION_LINES = 80
MAX_ROOT_MODULES = 10

# The rooms of ``multicrane``, lowest first; docs/architecture.md draws them in this order.
ROOMS = (
    "core", "sim", "scenario", "render", "tasks", "envs", "vector", "bounds", "episodes", "replay",
    "suite", "ifc", "training", "benchmark", "reports", "integrations", "cli",
)
# The root package: its ``__init__`` is the public face (it re-exports the environments, so it
# stands with ``envs``); the other root modules are helpers below every room.
PUBLIC_FACE_RANK = ROOMS.index("envs")


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


def rank(module: str) -> int | None:
    """The layer of a ``multicrane`` module: its room's index, -1 for a root helper, None when
    the module is not in ``multicrane`` (``policies``) or is the command's entry point."""
    parts = module.split(".")
    if parts[0] != "multicrane" or module == "multicrane.__main__":
        return None
    if len(parts) == 1:
        return PUBLIC_FACE_RANK
    if parts[1] in ROOMS:
        return ROOMS.index(parts[1])
    return -1


def downward_violations(graph: dict[str, set[str]]) -> list[str]:
    """Imports from a lower room to a higher one (a room's own package may import its modules)."""
    bad = []
    for m, deps in graph.items():
        low = rank(m)
        if low is None:
            continue
        for d in deps:
            high = rank(d)
            if high is not None and high > low:
                bad.append(f"{m} -> {d}")
    return sorted(bad)


def long_functions(mods: dict[str, Path], limit: int = MAX_FUNCTION_LINES) -> list[str]:
    found = []
    for name, path in mods.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > limit:
                    found.append(f"{name}.{node.name}: {n} lines")
    return sorted(found)


MODULES = module_files()
GRAPH = import_graph(MODULES)


def test_multicrane_never_imports_policies():
    assert upward_imports(GRAPH) == []


def test_no_import_cycles():
    assert cycles(GRAPH) == []


def test_no_import_from_a_lower_room_to_a_higher_one():
    assert downward_violations(GRAPH) == []


def test_every_folder_is_a_room_that_says_what_it_may_import():
    package = ROOT / "multicrane"
    folders = sorted(p.name for p in package.iterdir() if (p / "__init__.py").exists())
    assert folders == sorted(ROOMS)
    for room in ROOMS:
        doc = ast.get_docstring(ast.parse((ROOT / "multicrane" / room / "__init__.py").read_text()))
        assert doc and "May import" in doc, f"multicrane/{room}/__init__.py: say what it may import"


def test_the_root_keeps_the_public_face_and_a_few_helpers():
    root = sorted(p.name for p in (ROOT / "multicrane").glob("*.py"))
    assert len(root) <= MAX_ROOT_MODULES, root
    for name in root:
        if name in ("__init__.py", "__main__.py"):
            continue
        helper = f"multicrane.{name.removesuffix('.py')}"
        assert GRAPH[helper] == set(), f"{helper} is a shared helper: it imports nothing of ours"


@pytest.mark.parametrize("name", sorted(MODULES))
def test_module_says_its_job_and_is_small(name):
    path = MODULES[name]
    text = path.read_text()
    doc = ast.get_docstring(ast.parse(text))
    assert doc and doc.strip().splitlines()[0].strip(), f"{path}: no module docstring"
    n = len(text.splitlines())
    assert n <= MAX_LINES, f"{path}: {n} lines; a module over 400 lines does two jobs"


def test_no_function_over_80_lines():
    assert long_functions(MODULES) == [], "a function over 80 lines does two jobs"


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


def test_checker_finds_an_import_from_a_lower_room_and_a_long_function(tmp_path):
    pkg = tmp_path / "multicrane"
    for room in ("sim", "envs"):
        (pkg / room).mkdir(parents=True)
        (pkg / room / "__init__.py").write_text(f'"""{room}."""\n')
    (pkg / "__init__.py").write_text('"""p."""\n')
    (tmp_path / "policies").mkdir()
    (pkg / "sim" / "rules.py").write_text('"""r."""\nfrom multicrane.envs import env\n')
    body = "".join("    x = 1\n" for _ in range(MAX_FUNCTION_LINES))
    (pkg / "envs" / "env.py").write_text(f'"""e."""\nimport multicrane.sim.rules\ndef f():\n{body}')
    mods = module_files(tmp_path)
    graph = import_graph(mods)
    assert downward_violations(graph) == [
        "multicrane.sim.rules -> multicrane.envs",
        "multicrane.sim.rules -> multicrane.envs.env",
    ]
    assert long_functions(mods) == [f"multicrane.envs.env.f: {MAX_FUNCTION_LINES + 1} lines"]
