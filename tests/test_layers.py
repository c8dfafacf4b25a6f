"""The import structure: no circle, and no import that runs back up a layer.

The modules' imports are read from their source (every ``import`` and ``from ... import``,
including those inside functions: a circle closed at call time is still a circle), so a new
module or a new import is checked without anyone updating a list. The layers, bottom to top:

1. the core: every module of ``groundsym`` not named below;
2. what presents the core to a person or an agent: ``groundsym.report``, ``groundsym.gym``;
3. the command line: ``groundsym.commands``, then ``groundsym.cli`` above it;
4. the plug-ins: ``sims`` and ``planners`` build on the core and know nothing of each other.
   The core finds them by name (``groundsym.registry``), never by import.

A module may import from its own layer and the layers below; two modules of one layer may not
import each other in a circle.
"""

from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx
import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("groundsym", "sims", "planners")

#: (module-name prefix, layer); the longest matching prefix decides.
LAYERS = (("groundsym", 0), ("groundsym.report", 1), ("groundsym.gym", 1), ("groundsym.commands", 2),
          ("groundsym.cli", 3), ("sims", 4), ("planners", 4))


def modules(root: Path, packages: tuple[str, ...] = PACKAGES) -> dict[str, tuple[Path, bool]]:
    """Module name -> (source file, is a package)."""
    found = {}
    for pkg in packages:
        for path in sorted((root / pkg).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            is_pkg = parts[-1] == "__init__"
            found[".".join(parts[:-1] if is_pkg else parts)] = (path, is_pkg)
    return found


def import_graph(root: Path, packages: tuple[str, ...] = PACKAGES) -> nx.DiGraph:
    """An edge A -> B for every import in module A of module B (both in ``packages``)."""
    mods = modules(root, packages)

    def known(name: str) -> str | None:
        while name and name not in mods:        # a name imported from a module: the module
            name = name.rpartition(".")[0]
        return name or None

    graph = nx.DiGraph()
    for name, (path, is_pkg) in mods.items():
        graph.add_node(name)
        here = name.split(".") if is_pkg else name.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = ".".join(here[:len(here) - node.level + 1] + ([node.module] if node.module else [])) \
                    if node.level else node.module or ""
                # ``from pkg import sub`` imports the submodule when there is one, else a name of pkg
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
            for target in targets:
                dest = known(target)
                if dest is not None and dest != name:
                    graph.add_edge(name, dest, line=node.lineno)
    return graph


def layer(module: str) -> tuple[int, str]:
    """(layer, the top package of a plug-in): plug-ins of one layer are still kept apart."""
    best = max((p for p, _ in LAYERS if module == p or module.startswith(p + ".")), key=len)
    return dict(LAYERS)[best], best if best in ("sims", "planners") else ""


def circles(graph: nx.DiGraph) -> list[list[str]]:
    return sorted(sorted(c) for c in nx.strongly_connected_components(graph) if len(c) > 1)


def upward(graph: nx.DiGraph) -> list[str]:
    """Imports of a higher layer, or of the other plug-in package."""
    bad = []
    for a, b, data in graph.edges(data=True):
        (la, pa), (lb, pb) = layer(a), layer(b)
        if lb > la or (lb == la and pa != pb):
            bad.append(f"{a} (line {data['line']}) imports {b}")
    return sorted(bad)


GRAPH = import_graph(ROOT)


def test_the_graph_covers_the_packages():
    assert len(GRAPH) > 100 and GRAPH.number_of_edges() > 300
    assert GRAPH.has_edge("groundsym.cli", "groundsym.errors")


def test_no_import_circle():
    assert circles(GRAPH) == []


def test_no_import_runs_up_a_layer():
    assert upward(GRAPH) == []


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """A small package tree written by hand: one circle and two arrows back up."""
    files = {
        "groundsym/__init__.py": "",
        "groundsym/low.py": "def f():\n    from .high import g   # closed at call time\n",
        "groundsym/high.py": "from . import low\n",
        "groundsym/fine.py": "from .low import f\nimport numpy\n",
        "groundsym/commands/__init__.py": "",
        "groundsym/commands/show.py": "from ..fine import f\n",
        "groundsym/report/__init__.py": "from ..commands.show import f\n",
        "sims/__init__.py": "", "sims/world.py": "from groundsym.fine import f\n",
        "planners/__init__.py": "", "planners/p.py": "import sims.world\n",
    }
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    return tmp_path


def test_the_checks_catch_what_they_are_for(tree: Path):
    graph = import_graph(tree)
    assert circles(graph) == [["groundsym.high", "groundsym.low"]]
    assert upward(graph) == ["groundsym.report (line 1) imports groundsym.commands.show",
                             "planners.p (line 1) imports sims.world"]
    assert not graph.has_edge("groundsym.fine", "numpy") and graph.has_edge("sims.world", "groundsym.fine")
