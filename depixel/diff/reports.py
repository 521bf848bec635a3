"""Reports of a folder comparison: JSON for scripts, JUnit XML for CI servers.

Both list every pair with its verdict and figures, in name order, and nothing that
changes from run to run (no times), so the same folders give the same bytes. The HTML
report for people is :mod:`.html`.
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from ..errors import report_text
from .folders import totals
from .pairs import DIFFERENT, ERROR, MISSING, NEW, PairResult

#: Characters XML 1.0 cannot hold (a file name may have them): written as \\xNN.
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def result_entry(result: PairResult, pictures_in: dict[str, str] | None = None) -> dict:
    """One pair as a JSON object; ``pictures_in`` maps a picture kind to the folder it was
    written in (the paths listed are joined to it)."""
    total = None if result.width is None or result.height is None else \
        result.width * result.height - result.ignored_pixels
    entry = {
        "name": report_text(result.name), "verdict": result.verdict, "baseline": _text(result.baseline),
        "current": _text(result.current),
        "width": result.width, "height": result.height, "different_pixels": result.different_pixels,
        "antialiased_pixels": result.antialiased_pixels, "ignored_pixels": result.ignored_pixels,
        "total_pixels": total, "ratio": result.ratio, "identical": result.identical, "error": _text(result.error),
    }
    folders = pictures_in or {}
    for kind, path in result.pictures:
        if kind in folders:
            entry[kind] = report_text(f"{folders[kind]}/{path}")
    return entry


def json_report(results: list[PairResult], status: str, settings: dict, pictures_in: dict[str, str] | None = None,
                updated: list[tuple[str, str]] | None = None) -> dict:
    """The ``--json`` report of a folder comparison: the overall status, the totals, the
    settings, every pair, and what ``--update`` changed."""
    settings = {key: report_text(value) if isinstance(value, str) else value for key, value in settings.items()}
    report = {"status": status, "same": status == "same", "totals": totals(results), **settings,
              "files": [result_entry(r, pictures_in) for r in results]}
    if updated is not None:
        report["updated"] = [{"action": action, "name": report_text(name)} for action, name in updated]
    return report


def junit_report(results: list[PairResult], allow_new: bool = False, allow_missing: bool = False,
                 suite: str = "depixel diff") -> bytes:
    """JUnit XML: one testcase per pair; a difference, or a missing or new file not allowed,
    is a failure with its figures; a file that could not be compared is an error; an
    allowed new or missing file is skipped."""
    counts = totals(results)
    failures = counts[DIFFERENT] + (0 if allow_new else counts[NEW]) + (0 if allow_missing else counts[MISSING])
    skipped = (counts[NEW] if allow_new else 0) + (counts[MISSING] if allow_missing else 0)
    attributes = {"name": suite, "tests": str(len(results)), "failures": str(failures),
                  "errors": str(counts[ERROR]), "skipped": str(skipped)}
    root = ET.Element("testsuites", attributes)
    suite_element = ET.SubElement(root, "testsuite", attributes)
    for result in results:
        case = ET.SubElement(suite_element, "testcase", {"classname": "depixel.diff", "name": _xml(result.name)})
        line = _xml(result.summary())
        allowed = (result.verdict == NEW and allow_new) or (result.verdict == MISSING and allow_missing)
        if allowed:
            ET.SubElement(case, "skipped", {"message": line + " (allowed)"})
        elif result.verdict == ERROR:
            ET.SubElement(case, "error", {"message": line, "type": ERROR}).text = line
        elif result.verdict in (DIFFERENT, NEW, MISSING):
            failure = ET.SubElement(case, "failure", {"message": line, "type": result.verdict})
            failure.text = _details(result)
    ET.indent(root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True) + b"\n"


def _details(result: PairResult) -> str:
    lines = [_xml(result.summary()), f"baseline: {_xml(result.baseline or '(none)')}",
             f"current: {_xml(result.current or '(none)')}"]
    if result.verdict == DIFFERENT:
        lines.append(f"anti-aliasing pixels (not counted): {result.antialiased_pixels}")
        if result.ignored_pixels:
            lines.append(f"masked pixels: {result.ignored_pixels}")
    return "\n".join(lines)


def _xml(text: str) -> str:
    """``text`` with the characters XML cannot hold written as escapes (the bytes of a name
    that were not UTF-8 as :func:`~depixel.errors.report_text` writes them)."""
    return _NOT_XML.sub(lambda m: f"\\x{ord(m.group()):02x}", report_text(text))


def _text(text: str | None) -> str | None:
    return None if text is None else report_text(text)
