"""The package's shape: stage subpackages, small modules, no import cycle (docs/design.md, Map).

Imports are read from the source (every ``import`` statement, inside functions and
``TYPE_CHECKING`` blocks too), not from a running interpreter, so a cycle hidden in a
function-level import is found as well.
"""
from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest
from conftest import ROOT

LIBRARY = ROOT / "depixel"
CLI = ROOT / "cli"
#: the stage folders a reader of the paper recognises (docs/design.md)
STAGES = ("prepare", "graph", "curves", "optimize", "svg", "render")
MAX_TOP_LEVEL_MODULES = 14
MAX_MODULE_LINES = 400


def module_name(path: Path) -> str:
    """``depixel.svg.writer`` for depixel/svg/writer.py, ``depixel_cli.pool`` for cli/pool.py."""
    if path.is_relative_to(CLI):
        parts = ("depixel_cli",) + path.relative_to(CLI).with_suffix("").parts
    else:
        parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def sources() -> dict[str, Path]:
    files = [*LIBRARY.rglob("*.py"), *(p for p in CLI.rglob("*.py") if "extension" not in p.parts)]
    return {module_name(p): p for p in sorted(files)}


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """The project modules ``name`` imports anywhere in its source."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            # `from pkg import mod` imports the module; `from pkg import name` the package
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base for alias in node.names]
        else:
            continue
        for target in targets:
            while target and target not in known:  # `import a.b.c` of a name inside a module
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


@functools.cache  # (three tests read it: the sources are parsed once)
def import_graph() -> dict[str, set[str]]:
    files = sources()
    known = set(files)
    return {name: imports_of(name, path, known) for name, path in files.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one node (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in sorted(graph):
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
                    work.append((child, iter(sorted(graph.get(child, ())))))
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
                    found.append(sorted(component))
    return found


def test_the_cycle_finder_finds_a_cycle_through_a_function_level_import():
    # the checker itself: a -> b at module level, b -> a inside a function
    graph = {"a": {"b"}, "b": {"a"}, "c": {"a"}}
    assert cycles(graph) == [["a", "b"]]
    assert cycles({"a": {"b"}, "b": set()}) == []
    tree_b = "def f():\n    from .a import x\n"
    path = ROOT / "tests" / "_cycle_probe.py"
    try:
        path.write_text(tree_b)
        assert imports_of("depixel.svg.b", path, {"depixel.svg.a", "depixel.svg.b"}) == {"depixel.svg.a"}
    finally:
        path.unlink()


def test_no_import_cycle_between_modules():
    assert cycles(import_graph()) == []


def test_no_import_cycle_between_the_subpackages():
    """Folder to folder, the imports point one way (docs/design.md, Map): a package's own
    modules are one node, top-level modules each their own."""
    def folder(name: str) -> str:
        parts = name.split(".")
        return ".".join(parts[:2]) if parts[0] == "depixel" and len(parts) > 2 else name
    packages: dict[str, set[str]] = {}
    for name, targets in import_graph().items():
        packages.setdefault(folder(name), set()).update(folder(t) for t in targets if folder(t) != folder(name))
    assert cycles(packages) == []
    # the package root re-exports the API from everywhere, and nothing in the library imports it
    assert not [name for name, targets in packages.items() if "depixel" in targets and name.startswith("depixel.")]


def test_the_library_never_imports_the_command_line():
    # depixel/__main__.py is the `python -m depixel` entry point: it runs the front end, and
    # nothing imports it
    leaks = {name: sorted(t for t in targets if t.startswith("depixel_cli"))
             for name, targets in import_graph().items()
             if (name.startswith("depixel.") or name == "depixel") and name != "depixel.__main__"}
    assert {name: t for name, t in leaks.items() if t} == {}


def test_top_level_holds_few_modules_and_the_stages_are_folders():
    top = sorted(p.name for p in LIBRARY.glob("*.py"))
    assert len(top) <= MAX_TOP_LEVEL_MODULES, top
    for stage in STAGES:
        init = LIBRARY / stage / "__init__.py"
        assert init.is_file(), f"depixel/{stage}/ is not a package"
        doc = ast.get_docstring(ast.parse(init.read_text()))
        assert doc and len(doc.splitlines()) >= 2, f"depixel/{stage}/__init__.py must say what the stage takes and gives"


@pytest.mark.parametrize("path", [p for p in [*LIBRARY.rglob("*.py"), *CLI.rglob("*.py")]],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_no_module_is_over_the_size_rule(path):
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_MODULE_LINES, f"{path.relative_to(ROOT)} has {lines} lines: split it by responsibility"


def test_pyproject_installs_every_package_folder():
    tomllib = pytest.importorskip("tomllib", reason="tomllib is Python 3.11's")
    configured = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    folders = {module_name(p) for p in [*LIBRARY.rglob("__init__.py"), *CLI.rglob("__init__.py")]}
    assert folders <= set(configured), sorted(folders - set(configured))


def test_every_folder_face_lists_its_modules_and_holds_no_code():
    """A folder's ``__init__.py`` is its docstring and ``__all__``, its modules: what ``dir()``
    and IDEs show, and what depixel/__init__.py loads on first use (one mechanism for all)."""
    import depixel

    faces = sorted(LIBRARY.glob("*/__init__.py"))
    assert sorted(depixel.FOLDERS) == sorted(face.parent.name for face in faces)
    for face in faces:
        body = ast.parse(face.read_text()).body
        assert all(isinstance(node, (ast.Expr, ast.Assign)) for node in body), f"{face}: code in a folder face"
        listed = [ast.literal_eval(node.value) for node in body
                  if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "__all__"]
        modules = sorted(p.stem for p in face.parent.glob("*.py") if not p.name.startswith("_"))
        assert listed and sorted(listed[0]) == modules, f"{face.relative_to(ROOT)}: __all__ is not its modules"


def test_a_folders_module_loads_on_first_use_and_dir_lists_it():
    import subprocess
    import sys

    code = ("import sys, depixel\n"
            "assert 'depixel.diff.html' not in sys.modules and 'html' in dir(depixel.diff)\n"
            "assert callable(depixel.diff.html.html_report) and 'depixel.diff.html' in sys.modules\n"
            "assert all(set(getattr(depixel, f).__all__) <= set(dir(getattr(depixel, f))) for f in depixel.FOLDERS)\n"
            "try:\n    depixel.svg.nothing\nexcept AttributeError as exc:\n    print(exc)\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "module 'depixel.svg' has no attribute 'nothing'"


def test_render_takes_the_products_and_imports_no_pipeline():
    """The stages figure draws what a run made; its caller runs the pipeline (docs/design.md)."""
    graph = import_graph()
    assert [name for name, targets in graph.items()
            if name.startswith("depixel.render") and "depixel.pipeline" in targets] == []
