"""The docs name what is there: docs/design.md's map lists every folder and module of the
tree, and no doc (README.md, docs/*.md) names a repository file that does not exist. And
design.md (decisions) and performance.md (today's figures) stay short."""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import ROOT

DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: the trees the map covers
TREES = ("depixel", "cli")
#: the folders of the repository a path may start with (``depixel_cli/`` is ``cli/`` installed)
TOP = ("depixel", "depixel_cli", "cli", "tests", "benchmarks", "fixtures", "docs", ".ci")
#: the package folders a module path may be written from (``optimize/energy.py``)
PACKAGES = ("prepare", "graph", "curves", "optimize", "svg", "render", "files", "diff", "convert", "dask",
            "inkscape")
EXTENSIONS = ("py", "md", "toml", "json", "png", "gif", "jpg", "webp", "inx", "sh", "txt", "yml", "yaml", "svg",
              "pdf")
#: names a doc shows on purpose although they do not exist (docs/api.md: the error for a missing input)
MEANT_MISSING = {"fixtures/missing.png"}

_EXT = "|".join(EXTENSIONS)
#: a path from a top folder with a known extension, anywhere in the text
FULL_PATH = re.compile(rf"(?<![\w./-])((?:{'|'.join(re.escape(t) for t in TOP)})/[\w./-]*\.(?:{_EXT}))(?![\w/-])")
#: in backticks: a module path from a package folder, or a bare module file name
MODULE_PATH = re.compile(rf"`((?:{'|'.join(PACKAGES)})/[\w/-]+\.py)`")
MODULE_NAME = re.compile(r"`([\w-]+\.py)`")
#: a Markdown link's target that is no URL and no anchor of the same page
LINK = re.compile(r"\]\((?![a-z]+:|#)([^)\s#]+)")


def named_paths(text: str) -> list[tuple[int, str, str]]:
    """``(line, kind, name)`` of every repository file a doc's text names: ``path`` (from a top
    folder), ``module`` (from a package folder, in backticks), ``file`` (a bare module name, in
    backticks), ``link`` (a Markdown link's target)."""
    found = []
    for number, line in enumerate(text.splitlines(), start=1):
        found += [(number, "path", m.group(1)) for m in FULL_PATH.finditer(line)]
        found += [(number, "module", m.group(1)) for m in MODULE_PATH.finditer(line)]
        found += [(number, "file", m.group(1)) for m in MODULE_NAME.finditer(line)]
        found += [(number, "link", m.group(1)) for m in LINK.finditer(line)]
    return found


def repository_files() -> set[str]:
    return {p.name for p in ROOT.rglob("*") if p.is_file() and not {".git", "__pycache__"} & set(p.parts)}


def missing(doc: Path, text: str, files: set[str]) -> list[str]:
    """The names in ``text`` (of ``doc``) that are no file of the repository."""
    def exists(path: str) -> bool:
        return (ROOT / re.sub(r"^depixel_cli/", "cli/", path)).exists()

    bad = []
    for number, kind, name in named_paths(text):
        if kind == "path":
            ok = name in MEANT_MISSING or exists(name)
        elif kind == "module":
            ok = any(exists(f"{tree}/{name}") for tree in TREES)
        elif kind == "file":
            ok = name in files
        else:
            ok = (doc.parent / name).exists()
        if not ok:
            bad.append(f"{doc.name}:{number}: {name}")
    return bad


def test_the_patterns_find_the_names_a_doc_can_get_wrong():
    text = """see `optimize/splitmix.py` and `relax.py`, depixel/optimize/splitmix.py,
    (tests/test_docs.py), [limits](limits.md#memory) and [nowhere](gone.md), `splitmix.py`;
    not out/ghost.svg, `svg/ui/ok.svg`, https://example.org/docs/x.md or `../shared/tools/judge.py`"""
    names = [(n, kind, name) for n, kind, name in named_paths(text)]
    assert names == [(1, "path", "depixel/optimize/splitmix.py"), (1, "module", "optimize/splitmix.py"),
                     (1, "file", "relax.py"), (2, "path", "tests/test_docs.py"), (2, "file", "splitmix.py"),
                     (2, "link", "limits.md"), (2, "link", "gone.md")]
    assert missing(ROOT / "docs" / "x.md", text, repository_files()) == [
        "x.md:1: depixel/optimize/splitmix.py", "x.md:1: optimize/splitmix.py", "x.md:2: splitmix.py",
        "x.md:2: gone.md"]


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_docs_name_only_files_that_exist(doc):
    """A file renamed or removed must take its mentions along: backticked module paths
    (``optimize/energy.py``) and names (``energy.py``), paths from the repository's top
    folders with a file extension, and relative links."""
    assert missing(doc, doc.read_text(), repository_files()) == []


def map_rows() -> dict[str, list[str]]:
    """docs/design.md's map: each folder row's folder and the modules it names."""
    text = (ROOT / "docs" / "design.md").read_text()
    section = re.search(r"^## Map\n(.*?)(?=^## )", text, flags=re.S | re.M)
    assert section, "docs/design.md has no '## Map' section"
    rows = {}
    for line in section.group(1).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and re.fullmatch(r"`[\w/]+/`", cells[0]):
            rows[cells[0].strip("`").rstrip("/")] = re.findall(r"`(\w+)`", cells[-1])
    return rows


def tree() -> dict[str, list[str]]:
    """Every folder of depixel/ and cli/ that holds Python modules, with their names (no ``__init__``)."""
    folders: dict[str, list[str]] = {}
    for top in TREES:
        for path in sorted((ROOT / top).rglob("*.py")):
            if "__pycache__" not in path.parts and path.stem != "__init__":
                folders.setdefault(path.parent.relative_to(ROOT).as_posix(), []).append(path.stem)
    return folders


def test_the_map_lists_every_folder_and_module():
    listed, there = map_rows(), tree()
    assert sorted(listed) == sorted(there), "folders: the map's rows against depixel/ and cli/"
    for folder, modules in there.items():
        unlisted, gone = sorted(set(modules) - set(listed[folder])), sorted(set(listed[folder]) - set(modules))
        assert not unlisted and not gone, f"docs/design.md's map, {folder}/: not listed {unlisted}, not there {gone}"


#: decisions and today's figures, not logs (the history is git's)
MAX_LINES = {"design.md": 450, "performance.md": 400}


@pytest.mark.parametrize("name", sorted(MAX_LINES))
def test_the_design_and_the_figures_stay_short(name):
    lines = len((ROOT / "docs" / name).read_text().splitlines())
    assert lines <= MAX_LINES[name], f"docs/{name} has {lines} lines: state decisions and today's figures"
