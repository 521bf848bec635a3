"""``depixel diff BASELINE CURRENT`` on folders: pairing, verdicts, exit codes, the JSON,
JUnit and HTML reports, ``--update``, and the report folders written whole."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
import xml.etree.ElementTree as ET
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote

import pytest
from conftest import FIXTURES

from depixel.diff.folders import pair_folders
from depixel.diff.staging import MARKER
from depixel_cli.main import main
from depixel_cli.options import Exit


@pytest.fixture(scope="module")
def renders(tmp_path_factory) -> Path:
    """heart, leaf and mushroom as SVG at 4x, a mushroom with one pixel changed, and the heart's PNG."""
    from PIL import Image

    folder = tmp_path_factory.mktemp("renders")
    for name in ("heart", "leaf", "mushroom"):
        assert main(["convert", str(FIXTURES / f"{name}.png"), "-o", str(folder / f"{name}.svg"), "--scale", "4"]) == 0
    edited = Image.open(FIXTURES / "mushroom.png").convert("RGB")
    edited.putpixel((4, 3), (24, 20, 37))  # one pixel of the cap's outline
    edited.save(folder / "mushroom-edited.png")
    assert main(["convert", str(folder / "mushroom-edited.png"), "-o", str(folder / "mushroom-edited.svg"),
                 "--scale", "4"]) == 0
    assert main(["render", str(folder / "heart.svg"), "-o", str(folder / "heart.png")]) == 0
    return folder


def make(root: Path, files: dict[str, bytes | str]) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data.encode() if isinstance(data, str) else data)
    return root


def read(renders: Path, name: str) -> bytes:
    return (renders / name).read_bytes()


@pytest.fixture
def folders(renders, tmp_path):
    """A baseline and a current folder with one pair of each verdict."""
    heart, leaf = read(renders, "heart.svg"), read(renders, "leaf.svg")
    base = make(tmp_path / "base", {
        "same.svg": heart,                                       # identical bytes
        "sub/retitled.svg": leaf,                                # other bytes, same picture
        "changed.svg": read(renders, "mushroom.svg"),            # one pixel of the art edited
        "gone.svg": leaf,                                        # missing
        "broken.svg": heart,                                     # the current one is not an SVG
        "icon.png": read(renders, "heart.png"),                  # paired with icon.svg
        "notes.txt": "not a render: ignored",
        ".hidden/x.svg": heart,
    })
    cur = make(tmp_path / "cur", {
        "same.svg": heart,
        "sub/retitled.svg": leaf.replace(b"<title>leaf.png</title>", b"<title>leaf</title>"),
        "changed.svg": read(renders, "mushroom-edited.svg"),
        "added.svg": heart,                                      # new
        "broken.svg": "<svg this is not",
        "icon.svg": heart,
    })
    return base, cur


def run_json(*argv: str, capsys) -> tuple[int, dict]:
    code = main(["diff", *argv, "--json"])
    return code, json.loads(capsys.readouterr().out)


def test_pairing_by_relative_path_and_by_name_up_to_the_extension(folders):
    base, cur = folders
    pairs = {(p.baseline, p.current) for p in pair_folders(base, cur)}
    assert pairs == {("same.svg", "same.svg"), ("sub/retitled.svg", "sub/retitled.svg"),
                     ("changed.svg", "changed.svg"), ("gone.svg", None), (None, "added.svg"),
                     ("broken.svg", "broken.svg"), ("icon.png", "icon.svg")}


def test_each_verdict_with_its_figures(folders, capsys):
    base, cur = folders
    code, report = run_json(str(base), str(cur), "-j", "1", capsys=capsys)
    assert code == Exit.FAILED
    verdicts = {f["name"]: f["verdict"] for f in report["files"]}
    assert verdicts == {"same.svg": "same", "sub/retitled.svg": "same", "changed.svg": "different",
                        "gone.svg": "missing", "added.svg": "new", "broken.svg": "error", "icon.svg": "same"}
    assert report["totals"] == {"same": 3, "different": 1, "missing": 1, "new": 1, "error": 1}
    by_name = {f["name"]: f for f in report["files"]}
    assert by_name["same.svg"]["identical"] and not by_name["sub/retitled.svg"]["identical"]
    changed = by_name["changed.svg"]
    assert changed["different_pixels"] > 0 and (changed["width"], changed["height"]) == (64, 56)
    assert "broken.svg" in by_name["broken.svg"]["error"] and "\n" not in by_name["broken.svg"]["error"]
    assert report["status"] == "different" and report["same"] is False


def test_exit_codes_and_allowances(folders, renders, tmp_path, capsys):
    base, cur = folders
    (cur / "changed.svg").write_bytes(read(renders, "mushroom.svg"))
    (cur / "broken.svg").unlink()
    (base / "broken.svg").unlink()
    assert main(["diff", str(base), str(cur)]) == Exit.FAILED  # one missing, one new
    assert main(["diff", str(base), str(cur), "--allow-new"]) == Exit.FAILED
    assert main(["diff", str(base), str(cur), "--allow-new", "--allow-missing"]) == Exit.OK
    out = capsys.readouterr().out
    assert out.splitlines()[-1] == "same: 6 files: 4 same, 1 missing, 1 new (new and missing allowed)"
    (base / "gone.svg").unlink()
    (cur / "added.svg").unlink()
    assert main(["diff", str(base), str(cur)]) == Exit.OK
    # nothing could be compared: only errors, or no render at all
    bad = make(tmp_path / "bad", {"a.svg": "<svg", "b.png": "not a PNG"})
    assert main(["diff", str(bad), str(bad)]) == Exit.USAGE  # identical, but unreadable: still an error
    assert "error: 2 files: 2 error" in capsys.readouterr().out
    empty = make(tmp_path / "empty", {})
    assert main(["diff", str(empty), str(empty)]) == Exit.USAGE
    capsys.readouterr()
    # a folder against a file is a usage error, one line
    assert_usage(["diff", str(base), str(FIXTURES / "heart.png")], "is a folder but", capsys)


def assert_usage(argv: list[str], words: str, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == Exit.USAGE
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1, err


def test_parallel_run_gives_the_same_report(folders, capsys):
    base, cur = folders
    one = run_json(str(base), str(cur), "-j", "1", capsys=capsys)
    two = run_json(str(base), str(cur), "-j", "2", capsys=capsys)
    assert one == two


def test_junit_report_is_valid_xml_with_a_testcase_per_file(folders, tmp_path, capsys):
    base, cur = folders
    weird = "odd <&> \"name\" \x01.svg"  # a name XML must escape, and a character it cannot hold
    (cur / weird).write_bytes((cur / "same.svg").read_bytes())
    junit = tmp_path / "diff.xml"
    assert main(["diff", str(base), str(cur), "--junit", str(junit), "--allow-missing"]) == Exit.FAILED
    root = ET.parse(junit).getroot()
    suite = root.find("testsuite")
    cases = suite.findall("testcase")
    assert len(cases) == 8 == int(suite.get("tests"))
    outcome = {c.get("name"): [child.tag for child in c] for c in cases}
    assert outcome["changed.svg"] == ["failure"] and outcome["added.svg"] == ["failure"]
    assert outcome["gone.svg"] == ["skipped"] and outcome["broken.svg"] == ["error"]
    assert outcome["same.svg"] == [] and outcome["odd <&> \"name\" \\x01.svg"] == ["failure"]
    assert (suite.get("failures"), suite.get("errors"), suite.get("skipped")) == ("3", "1", "1")
    failure = next(c for c in cases if c.get("name") == "changed.svg").find("failure")
    assert "pixels differ" in failure.get("message") and failure.get("type") == "different"


class _Images(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.sources: list[str] = []
        self.anchors: list[str] = []
        self.ids: list[str] = []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "img":
            self.sources.append(attrs["src"])
        if tag == "a" and attrs.get("href", "").startswith("#"):
            self.anchors.append(attrs["href"][1:])
        if "id" in attrs:
            self.ids.append(attrs["id"])


def test_html_report_references_only_pictures_it_wrote(folders, tmp_path, capsys):
    base, cur = folders
    report = tmp_path / "report"
    diffs = tmp_path / "diffs"
    assert main(["diff", str(base), str(cur), "--html", str(report), "--diff-out", str(diffs)]) == Exit.FAILED
    page = (report / "index.html").read_text()
    parser = _Images()
    parser.feed(page)
    assert parser.sources and all((report / unquote(src)).is_file() for src in parser.sources)
    assert set(parser.anchors) <= set(parser.ids)
    names = {unquote(src).split("/", 1)[1] for src in parser.sources}
    assert {"changed.svg.baseline.png", "changed.svg.current.png", "changed.svg.diff.png",
            "added.svg.current.png", "gone.svg.baseline.png"} <= names
    assert "http:" not in page and "https:" not in page  # offline
    assert sorted(p.name for p in diffs.iterdir()) == [MARKER, "changed.svg.diff.png"]
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    # a rerun replaces its own report; a folder of the user's is never replaced
    assert main(["diff", str(base), str(cur), "--html", str(report)]) == Exit.FAILED
    mine = make(tmp_path / "mine", {"keep.txt": "mine"})
    capsys.readouterr()
    assert main(["diff", str(base), str(cur), "--html", str(mine)]) == Exit.USAGE
    assert "not a report of depixel diff" in capsys.readouterr().err
    assert (mine / "keep.txt").read_text() == "mine"


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(chromium() is None, reason="chromium is not installed (Debian: apt-get install chromium)")
def test_html_report_loads_in_chromium_and_shows_the_changed_files(folders, tmp_path):
    base, cur = folders
    report = tmp_path / "report"
    assert main(["diff", str(base), str(cur), "--html", str(report)]) == Exit.FAILED
    with tempfile.TemporaryDirectory() as profile:
        run = subprocess.run([chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                              "--disable-background-networking", "--disable-component-update", "--disable-sync",
                              f"--user-data-dir={profile}", "--virtual-time-budget=5000", "--dump-dom",
                              (report / "index.html").as_uri()], capture_output=True, text=True, timeout=120)
    dom = run.stdout
    assert run.returncode == 0 and "<body" in dom, run.stderr[-500:]
    # the page's script counted its pictures once all were loaded or failed: all loaded
    images = dom.split('data-images="', 1)[1].split('"', 1)[0]
    loaded, total = map(int, images.split("/"))
    assert total >= 5 and loaded == total
    for name in ("changed.svg", "added.svg", "gone.svg", "broken.svg"):
        assert f"<h2>{name} " in dom
    assert "<h2>same.svg" not in dom


def test_update_makes_the_next_run_same(folders, capsys):
    base, cur = folders
    (cur / "broken.svg").write_bytes((base / "broken.svg").read_bytes())  # errors are never copied
    code = main(["diff", str(base), str(cur), "--update"])
    out = capsys.readouterr().out
    assert "updated: changed.svg" in out and "added: added.svg" in out and "removed" not in out
    assert code == Exit.FAILED  # gone.svg is still missing: kept without --prune
    assert (base / "gone.svg").exists()
    assert main(["diff", str(base), str(cur), "--update", "--prune"]) == Exit.OK
    assert "removed: gone.svg" in capsys.readouterr().out and not (base / "gone.svg").exists()
    assert (base / "changed.svg").read_bytes() == (cur / "changed.svg").read_bytes()
    assert main(["diff", str(base), str(cur)]) == Exit.OK
    assert capsys.readouterr().out.splitlines()[-1].startswith("same: 6 files: 6 same")


def test_update_replaces_a_baseline_of_another_format(renders, tmp_path, capsys):
    base = make(tmp_path / "base", {"icon.png": read(renders, "heart.png")})
    cur = make(tmp_path / "cur", {"icon.svg": read(renders, "leaf.svg")})  # square too: compared
    assert main(["diff", str(base), str(cur), "--update"]) == Exit.OK
    assert sorted(os.listdir(base)) == ["icon.svg"]
    assert main(["diff", str(base), str(cur)]) == Exit.OK


def test_folder_options_need_folders(renders, capsys):
    svg = str(renders / "heart.svg")
    for flag in (["--update"], ["--html", "r"], ["--junit", "r.xml"], ["--allow-new"]):
        assert_usage(["diff", svg, svg, *flag], "compares folders", capsys)
