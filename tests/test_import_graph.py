"""demcal's import graph, read from the sources (issue 18, item 7).

Every module under ``src/demcal`` is parsed with :mod:`ast` (nothing is imported) and
its imports of demcal modules are sorted in two kinds:

* *eager*: run when the module is imported (module level, class bodies, ``try`` and
  ``if`` blocks at module level);
* *deferred*: inside a function or lambda, or under ``if TYPE_CHECKING:``; they run
  only when called, which is how a genuinely upward dependency (a CLI command drawing
  a report figure) is written without a cycle at import time.

The eager graph must have no cycle, neither between modules nor between top-level
packages (``demcal.campaign``, ``demcal.report``, ...; a top-level module such as
``demcal.errors`` counts as its own package). The package graph with the deferred
imports added must have none either: the command line (``demcal.cli``) sits above every
subsystem and no subsystem imports it. Nor may the module graph with the deferred
imports added (issue 39): an import moved into a function hides a circle from the
import system, not from a reader (``campaign.loop`` importing ``campaign.calibrate`` at
call time while ``calibrate`` imports ``loop`` was one); shared code moves down into a
module both import. :data:`DEFERRED_PACKAGE_CYCLES` and :data:`DEFERRED_MODULE_CYCLES`
are the allow-lists of cycles through deferred imports; they may only shrink: a new
cycle fails, and so does one that disappears while still listed.
"""

from __future__ import annotations

import ast
from collections import deque
from pathlib import Path

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

SRC = Path(__file__).resolve().parents[1] / "src" / "demcal"

#: Strongly connected sets of top-level packages when deferred (in-function) imports are
#: counted as well. Empty since the commands moved into the ``cli/`` package, the demo
#: workflow with them, and the calibration.json reader into ``campaign.chain`` (issue 18
#: item 7). Remove an entry when its cycle is gone; never add one.
DEFERRED_PACKAGE_CYCLES: list[set[str]] = []

#: Strongly connected sets of modules when deferred (in-function) imports are counted as
#: well. The campaign's circle (calibrate -> loop -> calibrate, runner -> chain -> config
#: -> loop) is gone since the loop's seeds, its noise and the solve step moved into
#: ``campaign.seeds``, ``campaign.noise`` and ``campaign.solve`` (issue 39 item 2).
#: Remove an entry when its cycle is gone; never add one.
DEFERRED_MODULE_CYCLES: list[set[str]] = []

#: The only modules outside ``demcal.cli`` that may import it: the entry points.
CLI_ENTRY_POINTS = {"demcal.__main__"}


def _modules() -> dict[str, Path]:
    """``{dotted name: file}`` for every module and package under ``src/demcal``."""
    out = {}
    for path in sorted(SRC.rglob("*.py")):
        parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _lazy_names(package: str) -> dict[str, str]:
    """``{name: submodule}`` from a package's ``lazy_exports(__name__, {...})`` call
    (:mod:`demcal._lazy`), so that ``from demcal.rsm import fit_response_surface`` is
    seen as an import of ``demcal.rsm.fit``, which it is on first use."""
    path = MODULES[package]
    if path.name != "__init__.py":
        return {}
    for node in ast.walk(ast.parse(path.read_text())):
        if (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "lazy_exports"
                and len(node.args) == 2):
            where = ast.literal_eval(node.args[1])
            return {name: f"{package}.{sub}" for sub, names in where.items() for name in names}
    return {}


def _owner(name: str) -> str:
    """The module ``name`` lives in: itself, or the nearest enclosing one."""
    while name not in MODULES:
        name = name.rpartition(".")[0]
    return name


def _targets(module: str, name: str | None) -> str:
    """The demcal module that ``from module import name`` (or ``import module``) loads."""
    if name is not None:
        if f"{module}.{name}" in MODULES:
            return f"{module}.{name}"
        lazy = _lazy_names(module) if module in MODULES else {}
        if name in lazy:
            return lazy[name]
    return _owner(module)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return "TYPE_CHECKING" in (getattr(test, "id", None), getattr(test, "attr", None))


def _imports(module: str) -> tuple[set[str], set[str]]:
    """``(eager, deferred)``: the demcal modules ``module`` imports, itself left out."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    eager: set[str] = set()
    deferred: set[str] = set()

    def visit(node: ast.AST, late: bool) -> None:
        for child in ast.iter_child_nodes(node):
            child_late = late or isinstance(
                child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            into = deferred if child_late else eager
            if isinstance(child, ast.Import):
                into.update(_targets(a.name, None) for a in child.names
                            if a.name.split(".")[0] == "demcal")
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package.split(".")[: len(package.split(".")) - (child.level - 1)]
                    source = ".".join(base + ([child.module] if child.module else []))
                else:
                    source = child.module or ""
                if source.split(".")[0] == "demcal":
                    into.update(_targets(source, a.name) for a in child.names)
            if isinstance(child, ast.If) and _is_type_checking(child):
                for part in child.body:
                    visit(ast.Module(body=[part], type_ignores=[]), True)
                for part in child.orelse:
                    visit(ast.Module(body=[part], type_ignores=[]), late)
                continue
            visit(child, child_late)

    visit(ast.parse(path.read_text(), str(path)), False)
    eager.discard(module)
    deferred.discard(module)
    return eager, deferred - eager


IMPORTS = {m: _imports(m) for m in MODULES}


def _package(module: str) -> str:
    """The top-level package (``demcal.campaign``) or top-level module a module is in."""
    return ".".join(module.split(".")[:2])


def _graph(deferred: bool = False, packages: bool = False) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for module, (eager, late) in IMPORTS.items():
        source = _package(module) if packages else module
        graph.setdefault(source, set())
        for target in eager | (late if deferred else set()):
            target = _package(target) if packages else target
            if target != source:
                graph[source].add(target)
                graph.setdefault(target, set())
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[set[str]]:
    """The strongly connected sets of more than one node.

    scipy (already a dependency) finds them; networkx is not a dependency, and
    :mod:`graphlib` reports only the first cycle it meets, not all of them.
    """
    nodes = sorted(graph)
    index = {n: i for i, n in enumerate(nodes)}
    rows = [index[a] for a in nodes for _ in graph[a]]
    cols = [index[b] for a in nodes for b in sorted(graph[a])]
    matrix = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(nodes), len(nodes)))
    count, labels = connected_components(matrix, directed=True, connection="strong")
    groups = [{nodes[i] for i in np.flatnonzero(labels == k)} for k in range(count)]
    return [g for g in groups if len(g) > 1]


def _one_cycle(graph: dict[str, set[str]], members: set[str]) -> list[str]:
    """A shortest cycle through the first member, staying inside ``members``."""
    start = min(members)
    came_from = {start: None}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        for nxt in sorted(graph[node] & members):
            if nxt == start:
                path = [node]
                while came_from[path[-1]] is not None:
                    path.append(came_from[path[-1]])
                return [*reversed(path), start]
            if nxt not in came_from:
                came_from[nxt] = node
                queue.append(nxt)
    return [start]


def _describe(graph: dict[str, set[str]], cycles: list[set[str]]) -> str:
    return "\n".join(f"  {sorted(c)}: e.g. {' -> '.join(_one_cycle(graph, c))}"
                     for c in cycles)


def test_the_parser_sees_both_kinds_of_import():
    # known edges, so that a parser that reads nothing cannot pass the tests below
    assert "demcal.measure.summary" in IMPORTS["demcal.measure.photo"][0]
    assert "demcal.measure.photo" in IMPORTS["demcal.measure.lab"][1]
    assert "demcal.campaign.config" in IMPORTS["demcal.campaign.runner"][0]
    assert "demcal.campaign.executors" in IMPORTS["demcal.campaign.config"][1]
    assert "demcal.campaign.loop" in IMPORTS["demcal.campaign.calibrate"][1]  # in a function
    assert "demcal.dem.simulation" in IMPORTS["demcal.dem"][0]        # relative import
    assert "demcal.rsm.fit" in IMPORTS["demcal.report.paper"][0]      # lazy_exports name
    assert "demcal.rsm.fit" in IMPORTS["demcal.cli.rsm"][1]           # TYPE_CHECKING
    assert "demcal.doe.design" in IMPORTS["demcal.cli.doe"][1]
    assert "demcal.cli" in IMPORTS["demcal.__main__"][0]


def test_no_cycle_between_modules_at_import_time():
    graph = _graph()
    cycles = _cycles(graph)
    assert not cycles, ("module-level imports form cycles (import one side inside the "
                        "function that needs it, or move the shared code down):\n"
                        + _describe(graph, cycles))


def test_no_cycle_between_packages_at_import_time():
    graph = _graph(packages=True)
    cycles = _cycles(graph)
    assert not cycles, ("module-level imports make top-level packages depend on each "
                        "other both ways:\n" + _describe(graph, cycles))


def _only_shrink(graph: dict[str, set[str]], allowed: list[set[str]], what: str, listed: str) -> None:
    found = _cycles(graph)
    new = [c for c in found if c not in allowed]
    gone = [c for c in allowed if c not in found]
    assert not new, (f"new {what} cycle(s) counting in-function imports; move the shared "
                     "code down into a module both import rather than list them:\n"
                     + _describe(graph, new))
    assert not gone, (f"listed {what} cycle(s) no longer found: {[sorted(c) for c in gone]}; "
                      f"update {listed} (found now:\n" + _describe(graph, found) + ")")


def test_package_cycles_through_deferred_imports_only_shrink():
    _only_shrink(_graph(deferred=True, packages=True), DEFERRED_PACKAGE_CYCLES, "package",
                 "DEFERRED_PACKAGE_CYCLES")


def test_module_cycles_through_deferred_imports_only_shrink():
    _only_shrink(_graph(deferred=True), DEFERRED_MODULE_CYCLES, "module", "DEFERRED_MODULE_CYCLES")


def test_no_subsystem_imports_the_command_line():
    upward = sorted(f"{module} -> {target}" for module, (eager, late) in IMPORTS.items()
                    if _package(module) != "demcal.cli" and module not in CLI_ENTRY_POINTS
                    for target in eager | late if _package(target) == "demcal.cli")
    assert not upward, ("the command line (demcal.cli) is the top layer; move what these "
                        "modules need out of it:\n  " + "\n  ".join(upward))
