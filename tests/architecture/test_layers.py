"""The package's layout by stage (docs/architecture.md): data flows one way, with no import circle.

Every import of one gibbsimpact module by another, module-level or inside a function, is read
from the source with ``ast``. A module may import from its own folder and from the folders
before it in STAGES, never from one after it; the only exceptions are the one-line alias
methods that the architecture allows (``Model.mass_matrix`` calls gibbsimpact.dynamics,
``Result.save`` calls gibbsimpact.io, ...), listed in ALIASES, and the command line's lazy
imports (it is the last stage, so it only imports upwards anyway).
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / "src" / "gibbsimpact"
STAGES = ["kernel", "model", "dynamics", "symbolic", "contact", "simulation", "plotting", "io", "case",
          "study", "cli"]
# (importing module, enclosing function): the alias methods that may import a later stage.
ALIASES = {
    ("model.model", f) for f in ("_dynamics", "_kinematics")  # what Model.mass_matrix, ... call
} | {("simulation.results", f) for f in ("save", "to_csv", "summary", "plot", "figure", "save_figures")
     } | {("simulation.results", "episodes")}  # Result.episodes calls simulation.episodes (which reads contacts)


def _modules():
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        yield ".".join(parts), path


def _imports(name: str, path: Path, text: str | None = None):
    """(target module, enclosing function name or None, line) of every package-internal import."""
    tree = ast.parse(path.read_text() if text is None else text)
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = []

    def visit(node, func):
        for child in ast.iter_child_nodes(node):
            f = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else func
            if isinstance(child, ast.ImportFrom) and child.level > 0:
                base = package[: len(package) - child.level + 1]
                mod = ".".join(base + ([child.module] if child.module else []))
                for alias in child.names:
                    sub = f"{mod}.{alias.name}" if mod else alias.name
                    found.append((sub if (SRC / sub.replace(".", "/")).exists()
                                  or (SRC / (sub.replace(".", "/") + ".py")).exists() else mod, f, child.lineno))
            elif isinstance(child, ast.ImportFrom) and (child.module or "").startswith("gibbsimpact"):
                found.append((child.module[len("gibbsimpact."):], f, child.lineno))
            visit(child, f)

    visit(tree, None)
    return found


def _stage(module: str) -> int:
    top = module.split(".")[0]
    return STAGES.index(top) if top in STAGES else -1  # the package's __init__/__main__: above all


def test_every_module_sits_in_a_stage_folder():
    loose = [m for m, p in _modules() if m and m.split(".")[0] not in STAGES and m != "__main__"]
    assert not loose, f"modules outside the stage folders: {loose}"


def test_no_module_imports_from_a_later_stage():
    wrong = []
    for name, path in _modules():
        if not name or name == "__main__":
            continue
        for target, func, line in _imports(name, path):
            if _stage(target) > _stage(name) and (name, func) not in ALIASES:
                wrong.append(f"{path.relative_to(SRC)}:{line} ({func or 'module level'}) imports {target}")
    assert not wrong, "imports against the flow of stages:\n" + "\n".join(wrong)


def test_no_import_circle():
    graph = {}
    for name, path in _modules():
        graph[name] = {t for t, f, _ in _imports(name, path)
                       if t and (name, f) not in ALIASES and t != name}
    # Depth-first search for a back edge.
    state, stack, circles = {}, [], []

    def dfs(u):
        state[u] = 1
        stack.append(u)
        for v in sorted(graph.get(u, ())):
            if v not in graph:
                continue
            if state.get(v) == 1:
                circles.append(stack[stack.index(v):] + [v])
            elif v not in state:
                dfs(v)
        stack.pop()
        state[u] = 2

    for u in sorted(graph):
        if u not in state and u not in ("", "__main__"):
            dfs(u)
    assert not circles, "import circles:\n" + "\n".join(" -> ".join(c) for c in circles)


def test_the_checks_see_an_import_against_the_flow():
    """The reader finds function-level relative imports (the kind that hid the old circles)."""
    code = "def f():\n    from ..simulation.results import Result\n"
    found = _imports("kernel.probe", SRC / "kernel" / "probe.py", code)
    assert found == [("simulation.results", "f", 2)]
    assert _stage("simulation.results") > _stage("kernel.probe")
