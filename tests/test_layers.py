"""The packages of dpiil_rl form layers (docs/design.md): a package imports only from packages of lower
layers (and from itself). Imports under ``if TYPE_CHECKING:`` are annotations, not dependencies, and are
not counted. The test fails on any import against the layers, naming the file and the line."""

from __future__ import annotations

import ast

from tests.conftest import ROOT

#: lowest first; a package may import the packages of the layers before its own
LAYERS: tuple[tuple[str, ...], ...] = (
    ("utils",),
    ("records", "data", "modules", "plots"),
    ("robots", "mocap"),
    ("envs",),
    ("experts",),
    ("collectors", "loggers"),
    ("hooks",),
    ("methods",),
    ("training",),
    ("study",),
    ("cli", "bench"),
)
RANK = {pkg: i for i, layer in enumerate(LAYERS) for pkg in layer}


def _runtime_imports(tree: ast.AST) -> list[tuple[int, str]]:
    """``(line, module)`` of every ``dpiil_rl`` import outside ``if TYPE_CHECKING:`` blocks."""
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for inner in node.body:
                skip.update(id(n) for n in ast.walk(inner))
    out = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("dpiil_rl."):
            out.append((node.lineno, node.module))
        elif isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.startswith("dpiil_rl.")]
    return out


def violations() -> list[str]:
    found = []
    for path in sorted((ROOT / "dpiil_rl").rglob("*.py")):
        rel = path.relative_to(ROOT / "dpiil_rl")
        if len(rel.parts) < 2 or rel.parts[0] == "configs":
            continue  # dpiil_rl/__init__.py; the config tree (YAML, no code)
        pkg = rel.parts[0]
        assert pkg in RANK, f"dpiil_rl/{pkg}: a package the layers do not place (add it to LAYERS and docs/design.md)"
        for line, module in _runtime_imports(ast.parse(path.read_text())):
            target = module.split(".")[1]
            if target != pkg and RANK.get(target, 99) >= RANK[pkg]:
                found.append(
                    f"dpiil_rl/{rel}:{line}: {pkg} (layer {RANK[pkg]}) imports {module} (layer {RANK.get(target, '?')})"
                )
    return found


def test_every_import_follows_the_layers():
    assert violations() == []


def test_the_layers_are_written_in_the_design_document():
    text = (ROOT / "docs" / "design.md").read_text()
    for layer in LAYERS:
        for pkg in layer:
            assert f"`{pkg}`" in text, f"docs/design.md does not place {pkg}"


def test_a_violation_is_found(tmp_path, monkeypatch):
    """The check itself can fail: an upward import is reported."""
    tree = ast.parse(
        "from dpiil_rl.training.factory import build_trainer\nif TYPE_CHECKING:\n    from dpiil_rl.study import x\n"
    )
    assert _runtime_imports(tree) == [(1, "dpiil_rl.training.factory")]
