"""The engine apart from its research harness (issue 19, item 5): no module of the engine
imports the paper's reproduction (``vibroimpact.paper``) or the benchmarks and peer drivers
(``vibroimpact.benchmarks``), read from the source with ``ast`` (top-level and lazy imports
alike). The one seam is the command line's ``reproduce`` and ``bench``: their ``main``
imports the harness when the command runs."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "python" / "vibroimpact"
HARNESS = ("vibroimpact.paper", "vibroimpact.benchmarks")
#: Not the engine: the harness itself and the docs generator (its worked examples are the
#: paper's cases).
OUTSIDE_THE_ENGINE = ("paper", "benchmarks", "docs.py")
#: The seam: (module, function) -> the harness module it may import.
SEAM = {
    ("cli/reproduce.py", "main"): "vibroimpact.paper.reproduce",
    ("cli/bench.py", "main"): "vibroimpact.benchmarks.command",
}


def _module_name(path: Path) -> str:
    """The dotted name of ``path`` (``pkg.__init__`` for a package, so that a relative import
    of level 1 resolves to the package itself)."""
    return ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)


def harness_imports(source: str, module: str) -> list[tuple[str, str]]:
    """``(enclosing function or "<module>", imported module)`` for every import of the harness
    in ``source`` (the module ``module``, so that relative imports resolve)."""
    found: list[tuple[str, str]] = []

    def visit(node: ast.AST, where: str) -> None:
        for child in ast.iter_child_nodes(node):
            inner = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) \
                else where
            names: list[str] = []
            if isinstance(child, ast.Import):
                names = [alias.name for alias in child.names]
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    package = module.split(".")[: -child.level]
                    base = ".".join([*package, base] if base else package)
                names = [base] + [f"{base}.{alias.name}" for alias in child.names]
            for name in names:
                if any(name == h or name.startswith(h + ".") for h in HARNESS):
                    found.append((where, name))
                    break
            visit(child, inner)

    visit(ast.parse(source), "<module>")
    return found


def _engine_modules() -> list[Path]:
    return [p for p in sorted(PACKAGE.rglob("*.py"))
            if p.relative_to(PACKAGE).parts[0] not in OUTSIDE_THE_ENGINE]


def test_the_engine_imports_nothing_of_the_harness_but_through_the_cli_seam() -> None:
    seen: dict[tuple[str, str], str] = {}
    for path in _engine_modules():
        rel = path.relative_to(PACKAGE).as_posix()
        for where, name in harness_imports(path.read_text(encoding="utf-8"), _module_name(path)):
            allowed = SEAM.get((rel, where))
            assert name == allowed, f"{rel} ({where}) imports {name}"
            seen[(rel, where)] = name
    assert seen == SEAM, "the CLI's seam to the harness moved; update SEAM and the CLI's docs"


def test_the_check_sees_every_form_of_import() -> None:
    """The checker is not blind: top-level, lazy, ``from`` and relative imports of the
    harness are found, and imports of the engine are not."""
    source = (
        "import vibroimpact.paper.cases\n"
        "from vibroimpact import benchmarks\n"
        "def f():\n"
        "    from vibroimpact.benchmarks.peers import table\n"
        "    from ..paper import report\n"
        "    from vibroimpact import paperwork, contact\n"
    )
    assert harness_imports(source, "vibroimpact.sweeps.runner") == [
        ("<module>", "vibroimpact.paper.cases"),
        ("<module>", "vibroimpact.benchmarks"),
        ("f", "vibroimpact.benchmarks.peers"),
        ("f", "vibroimpact.paper"),
    ]
    assert len(_engine_modules()) > 40  # the walk reaches the subpackages
