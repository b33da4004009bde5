"""The layout the redesign promised (issue 17), checked on the source: no import circle anywhere in the
package (imports inside functions count), nothing outside a model's folder asks which model it holds,
the judges import no generator code, and the CLI is imported by nothing in the library."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "skelarm_sym"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in PACKAGE.rglob("*.py")}


def imports(path: Path, name: str, known: set[str]) -> set[str]:
    """Every module of the package that running ``path`` may execute: what it imports (at module level or
    inside functions; not under ``if TYPE_CHECKING``), and the ``__init__`` of each package on the way
    that is not one of its own (those run before it)."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text())
    skipped = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skipped |= {id(x) for x in ast.walk(node)}
    found = set()
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            submodules = [f"{base}.{alias.name}" for alias in node.names if f"{base}.{alias.name}" in known]
            targets = submodules if len(submodules) == len(node.names) else [base] + submodules
        else:
            continue
        for target in targets:
            while target and target not in known:
                target = target.rpartition(".")[0]
            parts = target.split(".")
            chain = {".".join(parts[:k]) for k in range(1, len(parts) + 1)}
            own = {".".join(name.split(".")[:k]) for k in range(1, name.count(".") + 2)}
            found |= {t for t in chain - own if t in known}
    return found


def graph() -> dict[str, set[str]]:
    mods = modules()
    known = set(mods)
    return {name: imports(path, name, known) for name, path in mods.items()}


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, result = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                result.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return result


def test_the_import_graph_has_no_circle():
    found = cycles(graph())
    assert not found, found


def test_the_detector_finds_a_circle():
    """The cycle finder is not vacuous: a planted circle is found."""
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_the_cli_is_imported_by_nothing():
    importers = [name for name, deps in graph().items() if "skelarm_sym.cli" in deps and name != "skelarm_sym.__main__"]
    assert importers == []


MODEL_CLASSES = ("PlanarArm", "DiffDrive", "Chain", "Joint")
MODEL_ATTRIBUTES = ("lengths", "track", "joints", "limits", "coordinates", "links")


def test_nothing_outside_a_models_folder_asks_which_model_it_holds():
    """No isinstance on a model class and no probe of a model's attributes outside models/ (the registry
    dispatches: models/registry.py is the one place that compares types)."""
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        relative = path.relative_to(PACKAGE).as_posix()
        if relative.startswith("models/"):
            continue
        text = path.read_text()
        for cls in MODEL_CLASSES:
            if re.search(rf"isinstance\([^)]*\b{cls}\b", text):
                offenders.append(f"{relative}: isinstance {cls}")
        for attr in MODEL_ATTRIBUTES:
            if re.search(rf"(getattr|hasattr)\([^)]*model[^)]*[\"']{attr}[\"']", text) or re.search(rf"\bmodel\.{attr}\b", text):
                offenders.append(f"{relative}: model.{attr}")
    assert offenders == []


@pytest.mark.parametrize("judge", ["models/planar/reference.py", "models/diffdrive/reference.py", "models/chain/reference.py",
                                   "models/chain/reference_inverse.py", "models/reference_linalg.py", "reference.py"])
def test_the_judges_import_no_generator_code(judge):
    path = PACKAGE / judge
    name = module_name(path)
    deps = imports(path, name, set(modules()))
    allowed_prefixes = ("skelarm_sym.models.planar.reference", "skelarm_sym.models.diffdrive.reference",
                        "skelarm_sym.models.chain.reference", "skelarm_sym.models.reference_linalg", "skelarm_sym.errors")
    bad = [d for d in deps if not d.startswith(allowed_prefixes) and d not in ("skelarm_sym", "skelarm_sym.models",
                                                                               "skelarm_sym.models.planar", "skelarm_sym.models.diffdrive",
                                                                               "skelarm_sym.models.chain")]
    assert bad == [], bad
