"""The harness's packages import each other without cycles.

Every ``import`` statement of every ``.py`` file of the packages is read with ``ast`` -- at module level
and inside functions (a function-level import that closes a loop is a cycle that merely waits for the
call) -- and resolved to the module it loads: relative imports against the importing package,
``from pkg import name`` to ``pkg.name`` when that is a submodule, and an import of ``a.b.c`` from outside
package ``a`` also to ``a`` and ``a.b``, whose ``__init__`` runs first.  Imports under
``if TYPE_CHECKING:`` count too: they never run, but a type named across a loop is a dependency all the same.
The graph of modules must have no cycle (a strongly connected component of more than one module, or a module
importing itself).
"""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("ked_quasi", "ked_linear", "exudyn_models", "compare", "ked_check", "ked_research", "ked_cli", "ked_bench",
            "ked_pytest")


def _modules() -> dict[str, Path]:
    """Module name -> file, for every .py file of the packages (a package is its ``__init__``)."""
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join(parts)] = path
    return found


def _import_nodes(tree: ast.AST):
    """Every Import/ImportFrom node of the tree, module- or function-level or under TYPE_CHECKING."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        stack.extend(ast.iter_child_nodes(node))


def _targets(module: str, is_package: bool, node: ast.Import | ast.ImportFrom, known: set[str]) -> set[str]:
    """The harness modules one import statement loads (names outside the packages are dropped)."""
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    else:
        if node.level:
            package = module.split(".") if is_package else module.split(".")[:-1]
            package = package[:len(package) - (node.level - 1)]
            base = ".".join(package + ([node.module] if node.module else []))
        else:
            base = node.module or ""
        submodules = [f"{base}.{alias.name}" for alias in node.names if f"{base}.{alias.name}" in known]
        # ``from pkg import name`` reads pkg itself unless every name is a submodule (then pkg is a parent).
        names = submodules + ([base] if len(submodules) < len(node.names) else [])
    loaded = set()
    for name in names:
        parts = name.split(".")
        for i in range(1, len(parts) + 1):
            prefix = ".".join(parts[:i])
            # The __init__ of a package the importer sits in is already running: not a new load.
            inside = module == prefix or module.startswith(prefix + ".")
            if prefix in known and (i == len(parts) or not inside):
                loaded.add(prefix)
    return loaded


def import_graph() -> dict[str, set[str]]:
    """Module -> the harness modules it imports (anywhere in its code)."""
    modules = _modules()
    known = set(modules)
    graph = {}
    for module, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        edges = set()
        for node in _import_nodes(tree):
            edges |= _targets(module, path.name == "__init__.py", node, known)
        edges.discard(module) if path.name == "__init__.py" else None
        graph[module] = edges
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle (a -> ... -> a) through each strongly connected component of more than one module,
    and every module importing itself (Tarjan's algorithm, iterative)."""
    index, low, on_stack, stack, components = {}, {}, set(), [], []
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
                if len(component) > 1 or node in graph[node]:
                    components.append(sorted(component))
    return [_cycle_in(graph, component) for component in sorted(components)]


def _cycle_in(graph: dict[str, set[str]], component: list[str]) -> list[str]:
    """A shortest cycle through the component's first module (breadth-first inside the component)."""
    start, members = component[0], set(component)
    parent = {start: None}
    queue = [start]
    while queue:
        node = queue.pop(0)
        for child in sorted(graph[node] & members):
            if child == start:
                path = [node]
                while parent[path[-1]] is not None:
                    path.append(parent[path[-1]])
                return [*reversed(path), start]
            if child not in parent:
                parent[child] = node
                queue.append(child)
    raise AssertionError(f"no cycle through {start}")  # unreachable for a strongly connected component


def test_graph_sees_every_kind_of_import():
    """The walker itself: a relative, a function-level and a ``from package import submodule`` import
    are resolved (each is written in the package sources, so a broken walker fails here)."""
    graph = import_graph()
    assert "compare.solvers" in graph["compare.solvers.quasi_static"]  # from compare.solvers import ...
    assert "exudyn_models.settings" in graph["exudyn_models"]  # from .settings import ... (relative)
    assert graph["ked_cli.main"], "ked_cli.main imports its commands"
    # A deliberate cycle is found and reported with its path.
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c", "a"]]
    assert cycles({"a": {"a"}}) == [["a", "a"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles():
    found = cycles(import_graph())
    assert not found, f"{len(found)} import cycle(s) among {', '.join(PACKAGES)}:\n" + "\n".join(
        " -> ".join(cycle) for cycle in found)


def test_the_executor_imports_nothing_of_the_campaign():
    # the executor (worker pools, Dask, crash isolation) is its own room: it may read the stop flag and nothing
    # else of the harness, so that every pool (campaigns, atlas, design check, figures) can use it
    graph = import_graph()
    assert graph["compare.executor"] <= {"compare.stopping"}, graph["compare.executor"]
    assert graph["compare.stopping"] == set()
    assert not any("compare.runner" in graph[m]
                   for m in ("ked_research.atlas.run", "ked_check.checkwork", "compare.plots"))


def test_the_check_pool_knows_no_check():
    # the design check's pool runs whatever task it is given; each task lives with its computation
    graph = import_graph()
    assert not graph["ked_check.checkwork"] & {"ked_check.check", "ked_check.critical"}, graph["ked_check.checkwork"]
    assert "ked_check.critical" not in graph["ked_check.check"]


LAYERS = ("ked_cli", ("ked_check", "ked_research", "ked_bench", "ked_pytest"), "compare", "exudyn_models",
          "ked_linear", "ked_quasi")
"""The packages from the top: commands; products (the design check, the research studies and atlas, the
benchmarks, the pytest plugin of regression checks); the campaign engine; the Exudyn reference (which may start
on the linear model's orbit, exudyn_models.start); the linear model; the scene model and quasi-static solver.
A package imports only packages below its own layer, and the one sideways edge: the research atlas calibrates the
check's verdict rule and writes the check's published limits (research -> check)."""
ALLOWED_SIDEWAYS = {("ked_research", "ked_check")}


def test_packages_import_only_downwards():
    # every edge between packages, function-level imports included, follows LAYERS
    rank = {p: i for i, layer in enumerate(LAYERS) for p in ((layer,) if isinstance(layer, str) else layer)}
    wrong = sorted({(m.split(".")[0], e.split(".")[0]) for m, es in import_graph().items() for e in es
                    if m.split(".")[0] != e.split(".")[0]
                    and rank[e.split(".")[0]] <= rank[m.split(".")[0]]
                    and (m.split(".")[0], e.split(".")[0]) not in ALLOWED_SIDEWAYS})
    assert not wrong, f"imports against the layers {LAYERS}: {wrong}"


MAX_MODULE_LINES = 600
"""A module longer than this holds more than one job (split it); the thesis emulation, one listing mirrored line by
line, is the one exception."""
LONG_BY_DESIGN = {"ked_quasi.thesis"}


def test_no_module_is_over_the_size_limit():
    long = {name: n for name, path in _modules().items()
            if (n := len(path.read_text().splitlines())) > MAX_MODULE_LINES and name not in LONG_BY_DESIGN}
    assert not long, long


MAX_PACKAGE_SHARE = 0.30
"""No package holds more than this share of the product lines: one that does has grown into several tenants
(the campaign engine, the design check and the research wing were once one package of half the house)."""


def test_no_package_holds_most_of_the_house():
    lines = {p: sum(len(path.read_text().splitlines()) for path in (ROOT / p).rglob("*.py")) for p in PACKAGES}
    total = sum(lines.values())
    big = {p: f"{n / total:.0%}" for p, n in lines.items() if n > MAX_PACKAGE_SHARE * total}
    assert not big, f"packages over {MAX_PACKAGE_SHARE:.0%} of {total} product lines: {big}"


KIND_MODULES = {"ked_quasi.scene", "ked_quasi.slidercrank", "ked_quasi.linkage", "ked_quasi.kinds"}
"""The modules that implement a linkage kind (or its seam): they may test a linkage's or a scene's type."""
KIND_BRANCHES_LEFT = {
    "compare.scenefile": "a slider-crank file without grid.mass_models gets the single-scene commands' default",
    "ked_check.published": "the published limits file keeps a four-bar's limits at its top level (its format)",
    "ked_cli.options": "the single-scene commands render a slider-crank's own columns (the midspan)",
    "ked_cli.quasi": "the single-scene commands render a slider-crank's own columns (the midspan)",
}
"""Branches on the linkage kind still outside the kind modules, each with its reason; a new one fails below."""
_KIND_TYPES = {"FourBar", "SliderCrank", "Scene", "SliderScene"}
_KIND_NAMES = {"SLIDER_KIND", "FOUR_BAR", "KIND", "FOUR_BAR_KIND"}


def _kind_branches(tree: ast.AST) -> list[int]:
    """Lines of isinstance/hasattr tests of a linkage or scene type, and comparisons with a kind's name."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("isinstance", "hasattr"):
            named = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)} | \
                {n.value for n in ast.walk(node) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
            if named & (_KIND_TYPES | {"fourbar", "slider_mass", "offset"}):
                lines.append(node.lineno)
        elif isinstance(node, ast.Compare):
            for side in (node.left, *node.comparators):
                if (isinstance(side, ast.Name) and side.id in _KIND_NAMES) or \
                        (isinstance(side, ast.Attribute) and side.attr in _KIND_NAMES) or \
                        (isinstance(side, ast.Constant) and side.value in ("slider-crank", "four-bar")):
                    lines.append(node.lineno)
                    break
    return lines


def test_no_branch_on_the_linkage_kind_outside_its_modules():
    # a linkage kind is one implementation per tier (ked_quasi.kinds, ked_linear.kinds, exudyn_models.kinds):
    # callers ask the scene's kind, they do not test its type
    found = {name: lines for name, path in _modules().items()
             if name not in KIND_MODULES and (lines := _kind_branches(ast.parse(path.read_text())))}
    assert set(found) <= set(KIND_BRANCHES_LEFT), {k: v for k, v in found.items() if k not in KIND_BRANCHES_LEFT}
    assert set(found) == set(KIND_BRANCHES_LEFT), f"no branch left in {set(KIND_BRANCHES_LEFT) - set(found)}: drop it"
