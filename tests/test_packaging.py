"""What a fresh `pip install -e .` gets: every import of the packages is declared, optional
extras are imported lazily behind a clear "install the extra" error, and the README's two set-up
commands are the ones `.ci/run` runs."""

from __future__ import annotations

import ast
import re
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("clutter_gym", "planners", "agents")
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def _name(requirement: str) -> str:
    return re.sub(r"[-_.]+", "-", re.split(r"[<>=!~;\[ ]", requirement, maxsplit=1)[0]).lower()


CORE = {_name(r) for r in PYPROJECT["dependencies"]}
EXTRAS = {
    extra: {_name(r) for r in requirements}
    for extra, requirements in PYPROJECT["optional-dependencies"].items()
}
DISTRIBUTIONS = metadata.packages_distributions()


def _distributions(module: str) -> set[str]:
    """The installed distributions that provide a top-level module."""
    return {_name(d) for d in DISTRIBUTIONS.get(module, [module])}


def _imports(tree: ast.Module) -> list[tuple[ast.stmt, str, bool]]:
    """(statement, top-level module, imported inside a function?) for every absolute import."""
    found: list[tuple[ast.stmt, str, bool]] = []

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inner = in_function or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef)
            if isinstance(child, ast.Import):
                found.extend((child, a.name.split(".")[0], inner) for a in child.names)
            elif isinstance(child, ast.ImportFrom) and child.level == 0 and child.module:
                found.append((child, child.module.split(".")[0], inner))
            visit(child, inner)

    visit(tree, False)
    return found


def _guarded(tree: ast.Module, statement: ast.stmt) -> bool:
    """Whether an import sits in a ``try`` whose handler catches ImportError."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Try) and any(statement is s for s in ast.walk(node)):
            for handler in node.handlers:
                caught = ast.unparse(handler.type) if handler.type else "BaseException"
                if "ImportError" in caught or "ModuleNotFoundError" in caught:
                    return True
    return False


SOURCES = sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py"))
EXTRA_MODULES = {"agents/learning/callbacks.py": "rl"}
"""Modules that subclass an extra's classes, so import it at module level; every other module
imports them lazily, where that extra has been required."""


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_import_is_declared(path: Path) -> None:
    tree = ast.parse(path.read_text())
    local = {*PACKAGES, "__future__", *sys.stdlib_module_names}
    for statement, module, lazy in _imports(tree):
        if module in local:
            continue
        where = f"{path.relative_to(ROOT)}:{statement.lineno} imports {module}"
        provided = _distributions(module)
        if provided & CORE:
            continue
        extras = [extra for extra, names in EXTRAS.items() if provided & names]
        assert extras, f"{where}, which no dependency or extra of pyproject.toml provides"
        if EXTRA_MODULES.get(str(path.relative_to(ROOT))) in extras:
            continue
        assert lazy, f"{where} at module level, but only the extra {extras[0]!r} provides it"
        assert _guarded(tree, statement), (
            f"{where} (extra {extras[0]!r}) without catching ImportError to say which extra "
            "to install"
        )


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_modules_of_an_extra_are_imported_lazily(path: Path) -> None:
    """In a function, or for the type checker only."""
    extra_modules = {m.removesuffix(".py").replace("/", ".") for m in EXTRA_MODULES}
    tree = ast.parse(path.read_text())
    for_types = [
        s
        for node in ast.walk(tree)
        if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING"
        for s in ast.walk(node)
    ]
    for statement, _, lazy in _imports(tree):
        names = [a.name for a in statement.names]  # type: ignore[attr-defined]
        module = getattr(statement, "module", None)
        imported = {*names, *(f"{module}.{name}" for name in names)} if module else set(names)
        if imported & extra_modules and not lazy:
            assert any(statement is s for s in for_types), (
                f"{path.relative_to(ROOT)}:{statement.lineno} imports a module of an extra "
                "at module level"
            )


def test_the_readme_gives_the_commands_ci_runs() -> None:
    readme = (ROOT / "README.md").read_text()
    commands = re.findall(r"^    (pip install .+)$", readme, flags=re.MULTILINE)
    assert len(commands) == 2, "the README gives exactly two set-up commands"
    ci = (ROOT / ".ci" / "run").read_text()
    for command in commands:
        assert command in ci, f".ci/run does not run the README's command: {command}"
    main_job, tests = commands
    assert main_job == "pip install -e . && clutter-gym demo"
    assert "pytest" in tests
