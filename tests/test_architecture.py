"""The package's shape, read from its sources (AST): no import circles, modules a reader can hold, kernels with few
arguments.

The import graph counts every ``import`` the interpreter can run — at module level and inside functions — except
those under ``if TYPE_CHECKING:``, which never run. ``from package import name`` is an edge to the submodule when
``name`` is one, else to the package. The parent packages an import runs first are not edges of their own (a
package's ``__init__`` importing its own modules is how packages are built).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import swarmtrack

SRC = Path(swarmtrack.__file__).parent
#: A module a reader can hold, and a function whose arguments a reader can keep apart (issue 22).
MAX_LINES = 800
MAX_PARAMETERS = 12


def _modules(root: Path = SRC, package: str = "swarmtrack") -> dict[str, Path]:
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root).with_suffix("").parts
        name = ".".join((package, *parts))
        out[name.removesuffix(".__init__")] = path
    return out


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or \
        (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(tree: ast.AST):
    """Every import node that can run (not under ``if TYPE_CHECKING:``)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.If) and _is_type_checking(node):
            stack.extend(node.orelse)
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        stack.extend(ast.iter_child_nodes(node))


def _target(name: str, modules: dict) -> str | None:
    """The module an absolute dotted name refers to (its longest prefix that is one of ours)."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def import_graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in _imports(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [_target(a.name, modules) for a in node.names]
            else:
                base = node.module or ""
                if node.level:
                    up = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join([*up, *([base] if base else [])])
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else _target(base, modules)
                           for a in node.names]
            graph[name].update(t for t in targets if t is not None and t != name)
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    out.append(sorted(component))
    return out


@pytest.mark.slow
def test_the_package_has_no_import_circle_counting_imports_inside_functions():
    found = circles(import_graph(_modules()))
    assert not found, "import circles:\n" + "\n".join(" <-> ".join(c) for c in found)


def test_the_circle_check_sees_a_circle_through_a_function_local_import(tmp_path):
    (tmp_path / "__init__.py").write_text("")
    (tmp_path / "a.py").write_text("from pkg import b\n")
    (tmp_path / "b.py").write_text("def f():\n    from pkg.a import x\n")
    (tmp_path / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg import a\n")
    graph = import_graph(_modules(tmp_path, "pkg"))
    assert circles(graph) == [["pkg.a", "pkg.b"]]  # and pkg.c, whose import never runs, is in none


def test_no_module_is_longer_than_a_reader_can_hold():
    long = {name: n for name, path in _modules().items() if (n := len(path.read_text().splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines: {long}"


def _parameters(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = fn.args
    names = [*a.posonlyargs, *a.args, *a.kwonlyargs]
    n = len(names) + (a.vararg is not None) + (a.kwarg is not None)
    return n - (bool(names) and names[0].arg in ("self", "cls"))


@pytest.mark.slow
def test_no_function_takes_more_than_twelve_parameters():
    wide = {}
    for name, path in _modules().items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _parameters(node) > MAX_PARAMETERS:
                wide[f"{name}.{node.name}"] = _parameters(node)
    assert not wide, f"functions over {MAX_PARAMETERS} parameters: {wide}"


@pytest.mark.slow
@pytest.mark.parametrize("module", ["swarmtrack.scenarios.schema"])
def test_the_schema_imports_no_simulator_code(module):
    banned = tuple(f"swarmtrack.{p}" for p in ("sim", "control", "estimation", "models", "network"))
    graph = import_graph(_modules())
    assert not {m for m in graph[module] if m.startswith(banned)}
