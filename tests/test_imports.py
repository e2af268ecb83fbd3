"""The import graph of the ugpcl package, read from the source with ``ast``: no cycle between modules, no chapter
module that imports the viewer or the benches, no private name imported from another module.

Every ``import`` and ``from ... import`` of a module counts, at any depth (an import inside a function is an edge
too: it runs the other module all the same). Relative imports are resolved; ``from . import x`` is an edge to the
submodule ``x`` when there is one. The folders setup.cfg installs inside the namespace (viewer/ as ugpcl.viewer,
clkernels/ as ugpcl.clkernels) are read where they lie. A package's ``__init__`` is a node of its own: importing
``ugpcl.scenes.boids`` is an edge to that module only, not to ``ugpcl`` or ``ugpcl.scenes``.
"""

from __future__ import annotations

import ast
import configparser
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "ugpcl"


@cache
def modules() -> dict[str, Path]:
    """Every module of the package by dotted name (a package by its own name, for its ``__init__.py``)."""
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    folders = {PACKAGE: ROOT / PACKAGE}
    for line in cfg["options"]["package_dir"].strip().splitlines():
        name, folder = (part.strip() for part in line.split("="))
        folders[name] = ROOT / folder
    found = {}
    for prefix, folder in folders.items():
        for path in folder.rglob("*.py"):
            parts = path.relative_to(folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join((*prefix.split("."), *parts))] = path
    return found


def is_package(name: str) -> bool:
    return modules()[name].name == "__init__.py"


def target(name: str) -> str | None:
    """The module of the package that ``name`` (a module or a name inside one) names: its longest prefix that is
    a module; None outside the package."""
    parts = name.split(".")
    for end in range(len(parts), 0, -1):
        prefix = ".".join(parts[:end])
        if prefix in modules():
            return prefix
    return None


def imports(name: str) -> list[tuple[str, str, int]]:
    """(module imported, name taken from it or "", line) for every import of module ``name`` inside the package."""
    tree = ast.parse(modules()[name].read_text(), str(modules()[name]))
    package = name if is_package(name) else name.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if (module := target(alias.name)) is not None:
                    out.append((module, "", node.lineno))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                source = ".".join([*base, node.module] if node.module else base)
            else:
                source = node.module or ""
            if target(source) != source:
                continue  # outside the package (numpy, pyopencl, ...)
            for alias in node.names:
                submodule = f"{source}.{alias.name}"
                if submodule in modules():
                    out.append((submodule, "", node.lineno))
                else:
                    out.append((source, alias.name, node.lineno))
    return out


@cache
def graph() -> dict[str, dict[str, int]]:
    """{module: {module it imports: line of the first such import}}."""
    edges: dict[str, dict[str, int]] = {}
    for name in modules():
        edges[name] = {}
        for module, _, line in imports(name):
            if module != name:
                edges[name].setdefault(module, line)
    return edges


def cycles(edges: dict[str, dict[str, int]]) -> list[tuple[list[str], set[str]]]:
    """(one cycle as a closed path of modules, every module of its tangle) per strongly connected component of
    more than one module."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components = []

    def visit(v: str) -> None:  # Tarjan; the graph has a few hundred nodes, recursion is fine
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(set(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    found = []
    for component in components:
        start = min(component)
        # the shortest way back to start inside the component (breadth first)
        paths = {start: [start]}
        frontier = [start]
        cycle = None
        while frontier and cycle is None:
            nxt = []
            for v in frontier:
                for w in sorted(edges[v]):
                    if w == start:
                        cycle = [*paths[v], start]
                        break
                    if w in component and w not in paths:
                        paths[w] = [*paths[v], w]
                        nxt.append(w)
                if cycle:
                    break
            frontier = nxt
        found.append((cycle, component))
    return sorted(found, key=lambda c: c[0])


def describe(cycle: list[str], component: set[str]) -> str:
    edges = graph()
    steps = [f"{a} (line {edges[a][b]})" for a, b in zip(cycle, cycle[1:], strict=False)]
    text = " -> ".join([*steps, cycle[-1]])
    others = sorted(component - set(cycle))
    return f"{text}; in the same tangle: {', '.join(others)}" if others else text


def test_the_graph_is_read():
    """The reader finds the modules and the edges it should (a broken reader would pass every test below)."""
    edges = graph()
    assert {"ugpcl", "ugpcl.cli", "ugpcl.scenes", "ugpcl.scenes.boids", "ugpcl.viewer.app"} <= set(edges)
    assert "ugpcl.viewer.views.boids" in edges and "ugpcl.clkernels" in edges
    assert "ugpcl.scene" in edges["ugpcl.scenes.boids"]  # from ..scene import ...
    assert "ugpcl.scenes" in edges["ugpcl.registry"]  # from . import scenes: the subpackage
    assert "ugpcl.viewer.offscreen" in edges["ugpcl"]  # inside a function of ugpcl/__init__.py
    assert "ugpcl.runtime" in edges["ugpcl.viewer.offscreen"]  # from ugpcl.runtime import ...: absolute


def test_no_import_cycle():
    found = cycles(graph())
    assert not found, "import cycles:\n" + "\n".join(describe(*c) for c in found)


def test_chapters_import_neither_viewer_nor_benches():
    """A scene module sits below the viewer and the benches: they import it, never the other way round."""
    above = ("ugpcl.viewer", "ugpcl.bench")
    bad = {
        f"{name} line {line} imports {module}"
        for name in modules()
        if name.startswith("ugpcl.scenes.")
        for module, _, line in imports(name)
        if module in above or module.startswith(tuple(f"{a}." for a in above))
    }
    assert not bad, "\n".join(sorted(bad))


def test_no_private_name_crosses_modules():
    """A name starting with ``_`` (dunders aside) stays in its module: what another module needs gets a public
    name."""

    def private(text: str) -> bool:
        return text.startswith("_") and not (text.startswith("__") and text.endswith("__"))

    bad = []
    for name in modules():
        for module, taken, line in imports(name):
            if module == name:
                continue
            short = taken or module.rpartition(".")[2]
            if private(short):
                bad.append(f"{name} line {line} imports {short} from {module if taken else module.rpartition('.')[0]}")
    assert not bad, "\n".join(bad)
