"""The HTML report of a folder comparison, for a reviewer: one static page, read offline.

``index.html`` has a summary table of every pair (verdict, pixels that differ, size) and,
for each changed file, the baseline, the current and the diff picture side by side, and a
flip view: one frame that shows the baseline or the current at the click of a checkbox (or
the key F), where a moved edge jumps. The pictures are PNG files in ``images/`` beside
it (written by :func:`depixel.diff.pairs.compare_pair`), small ones magnified without
smoothing over a checkerboard that shows transparency. Nothing is loaded from the
network; the page's few lines of script only count the pictures that failed to load
(shown at the top, so a report copied without its ``images/`` says so) and bind the key.
"""
from __future__ import annotations

import html
from urllib.parse import quote

from ..errors import report_text
from .folders import totals
from .pairs import DIFFERENT, ERROR, MISSING, NEW, SAME, PairResult

#: Folder of the pictures, beside index.html.
IMAGES = "images"
#: Magnified pictures are at most this wide or high (CSS pixels), at least 1x.
VIEW = 256

_STYLE = """
body { font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; color: #222; }
h1 { font-size: 1.4em; margin: 0 0 .3em; }
table { border-collapse: collapse; margin: 1em 0; }
th, td { padding: .25em .7em; border-bottom: 1px solid #ddd; text-align: left; }
td.n { text-align: right; font-variant-numeric: tabular-nums; }
.verdict { font-weight: 600; padding: .05em .5em; border-radius: .6em; }
.same { background: #dff3df; } .different { background: #ffd7d4; } .error { background: #ffe3b3; }
.new { background: #d9e8ff; } .missing { background: #eadcff; }
#broken { display: none; background: #ffd7d4; padding: .5em; }
section { border-top: 2px solid #ccc; margin-top: 1.5em; padding-top: .5em; }
.row { display: flex; flex-wrap: wrap; gap: 1.2em; align-items: flex-start; }
figure { margin: 0; } figcaption { font-size: .9em; color: #555; }
img { image-rendering: pixelated; display: block;
      background: repeating-conic-gradient(#ccc 0 25%, #fff 0 50%) 0 0 / 16px 16px; }
.flip input:checked ~ .frame .baseline, .flip input:not(:checked) ~ .frame .current { display: none; }
.flip input { display: none; } .flip label { cursor: pointer; font-size: .9em; color: #555; }
"""

_SCRIPT = """
(function () {
  var images = document.images, broken = 0, left = images.length;
  function done() {
    if (--left > 0) return;
    document.body.setAttribute("data-images", (images.length - broken) + "/" + images.length);
    if (broken) {
      var note = document.getElementById("broken");
      note.textContent = broken + " of " + images.length + " pictures could not be loaded: keep index.html "
        + "beside its images/ folder.";
      note.style.display = "block";
    }
  }
  if (!images.length) { left = 1; done(); }
  for (var i = 0; i < images.length; i++) {
    var img = images[i];
    if (img.complete) { if (!img.naturalWidth) broken++; done(); continue; }
    img.addEventListener("load", done);
    img.addEventListener("error", function () { broken++; done(); });
  }
  document.addEventListener("keydown", function (e) {
    if (e.key !== "f" && e.key !== "F") return;
    var boxes = document.querySelectorAll(".flip input");
    for (var j = 0; j < boxes.length; j++) boxes[j].checked = !boxes[j].checked;
  });
})();
"""


def html_report(results: list[PairResult], baseline: str, current: str, status: str, settings: str) -> str:
    """The page (module docstring); ``settings`` is one line describing the comparison."""
    counts = totals(results)
    shown = [r for r in results if r.verdict != SAME]
    summary = ", ".join(f"{n} {verdict}" for verdict, n in counts.items() if n)
    parts = [
        "<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
        f"<title>depixel diff: {_text(summary or 'no files')}</title>", f"<style>{_STYLE}</style>", "</head>",
        f'<body data-status="{status}">',
        f"<h1>depixel diff: {_text(status)}</h1>",
        f"<p>baseline <code>{_text(baseline)}</code> against current <code>{_text(current)}</code>: "
        f"{len(results)} files, {_text(summary or 'none')}.<br>{_text(settings)}</p>",
        '<p id="broken"></p>',
        _table(results),
    ]
    if shown:
        parts.append("<p>Changed files below: the baseline, the current and the differences (red: "
                     "different, yellow: anti-aliasing, not counted; pale blue: masked), and a flip view "
                     "(click it, or press F to flip them all).</p>")
    parts += [_section(i, r) for i, r in enumerate(results) if r.verdict != SAME]
    parts += [f"<script>{_SCRIPT}</script>", "</body>", "</html>", ""]
    return "\n".join(parts)


def _table(results: list[PairResult]) -> str:
    rows = ["<table>", "<thead><tr><th>file</th><th>verdict</th><th>pixels that differ</th><th>ratio</th>"
            "<th>size</th><th>note</th></tr></thead>", "<tbody>"]
    for i, r in enumerate(results):
        name = _text(r.name)
        if r.verdict != SAME:
            name = f'<a href="#f{i}">{name}</a>'
        figures = r.verdict in (SAME, DIFFERENT) and not r.identical
        size = f"{r.width}×{r.height}" if figures else ""
        note = _text(r.error or "") if r.verdict == ERROR else "identical files" if r.identical else \
            {NEW: "only in the current", MISSING: "only in the baseline"}.get(r.verdict, "")
        rows.append(f"<tr><td>{name}</td><td><span class=\"verdict {r.verdict}\">{r.verdict}</span></td>"
                    f"<td class=\"n\">{r.different_pixels if figures else ''}</td>"
                    f"<td class=\"n\">{f'{100 * r.ratio:.3g}%' if figures else ''}</td>"
                    f"<td class=\"n\">{size}</td><td>{note}</td></tr>")
    rows += ["</tbody>", "</table>"]
    return "\n".join(rows)


def _section(index: int, result: PairResult) -> str:
    pictures = dict(result.pictures)
    head = f'<section id="f{index}"><h2>{_text(result.name)} <span class="verdict {result.verdict}">' \
           f"{result.verdict}</span></h2><p>{_text(result.summary())}</p>"
    if result.verdict == ERROR:
        return head + "</section>"
    zoom = _zoom(result)
    figures = [_figure(pictures[kind], caption, zoom, result)
               for kind, caption in (("baseline", "baseline"), ("current", "current"), ("diff", "differences"))
               if kind in pictures]
    if not figures:
        figures = ["<p>(no picture: the file could not be drawn)</p>"]
    if "baseline" in pictures and "current" in pictures:
        figures.append(
            f'<figure class="flip"><input type="checkbox" id="flip{index}">'
            f'<label class="frame" for="flip{index}">{_img(pictures["baseline"], zoom, result, "baseline")}'
            f'{_img(pictures["current"], zoom, result, "current")}</label>'
            f'<figcaption><label for="flip{index}">flip: baseline ⇄ current (click, or F)</label>'
            f"</figcaption></figure>")
    return head + '<div class="row">' + "".join(figures) + "</div></section>"


def _figure(path: str, caption: str, zoom: int, result: PairResult) -> str:
    return f"<figure>{_img(path, zoom, result, caption)}<figcaption>{caption}</figcaption></figure>"


def _img(path: str, zoom: int, result: PairResult, alt: str) -> str:
    size = ""
    if result.width and result.height:
        size = f' width="{result.width * zoom}" height="{result.height * zoom}"'
    # the file's own bytes, a name's bytes that were not UTF-8 included, percent-encoded
    return f'<img class="{alt}" src="{IMAGES}/{quote(path.encode("utf-8", "surrogateescape"))}" alt="{alt}"{size}>'


def _zoom(result: PairResult) -> int:
    """Whole-number magnification that brings the picture near VIEW pixels (1 when larger)."""
    side = max(result.width or 0, result.height or 0)
    return max(1, VIEW // side) if side else 1


def _text(text: str) -> str:
    return html.escape(report_text(text))
