"""An independent reader of SVG path data (``d``), for the tests.

It follows the grammar of SVG 1.1 §8.3.9 exactly: a number ends where the next character
cannot continue it, so ``M 0.6.5`` is two coordinates (0.6, .5) and ``M 100-200`` two more
(100, -200), command letters may be left out where they repeat (after ``M``, ``L``), and
separators are whitespace or one comma. It returns absolute segments, so a test can compare
what a renderer will draw with the geometry the writer was given.
"""
from __future__ import annotations

import re

import numpy as np

_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_TOKEN = re.compile(rf"\s*(?:([MmLlHhVvCcSsQqTtZz])|({_NUMBER}))\s*,?")
ARITY = {"m": 2, "l": 2, "h": 1, "v": 1, "c": 6, "s": 4, "q": 4, "t": 2, "z": 0}


class PathSyntaxError(ValueError):
    pass


def tokens(d: str) -> list[str | float]:
    """Command letters and numbers of ``d``; raises PathSyntaxError on anything else."""
    out: list[str | float] = []
    pos = 0
    d = d.strip()
    while pos < len(d):
        m = _TOKEN.match(d, pos)
        if not m or m.end() == pos:
            raise PathSyntaxError(f"unexpected {d[pos:pos + 10]!r} at {pos}")
        out.append(m.group(1) if m.group(1) else float(m.group(2)))
        pos = m.end()
    return out


def parse(d: str) -> list[list[tuple]]:
    """Subpaths of absolute segments: ``("L", p0, p1)``, ``("Q", p0, c, p1)``,
    ``("C", p0, c1, c2, p1)``; each subpath closed with Z ends with the line back (if any)."""
    toks = tokens(d)
    if not toks or not isinstance(toks[0], str) or toks[0] not in "Mm":
        raise PathSyntaxError("path data must start with a moveto")
    subpaths: list[list[tuple]] = []
    cur = start = np.zeros(2)
    last_ctrl = None  # reflected by T (quadratic) / S (cubic)
    last_kind = ""
    i, cmd = 0, ""
    while i < len(toks):
        tok = toks[i]
        if isinstance(tok, str):
            cmd = tok
            i += 1
            if cmd in "Zz":
                if subpaths and np.abs(cur - start).max() > 1e-9:
                    subpaths[-1].append(("L", cur, start))
                cur = start
                last_kind = "Z"
                continue
        elif not cmd or cmd in "Zz":
            raise PathSyntaxError("numbers without a command")
        n = ARITY[cmd.lower()]
        args = toks[i : i + n]
        if len(args) < n or any(isinstance(a, str) for a in args):
            raise PathSyntaxError(f"{cmd} needs {n} numbers")
        i += n
        v = np.array(args, dtype=np.float64)
        rel = cmd.islower()
        base = cur if rel else np.zeros(2)
        c = cmd.upper()
        if c == "M":
            cur = start = base + v
            subpaths.append([])
            cmd = "l" if rel else "L"  # further pairs are lines
            last_kind = "M"
            continue
        if c == "L":
            p = base + v
            subpaths[-1].append(("L", cur, p))
        elif c == "H":
            p = np.array([v[0] + (cur[0] if rel else 0.0), cur[1]])
            subpaths[-1].append(("L", cur, p))
        elif c == "V":
            p = np.array([cur[0], v[0] + (cur[1] if rel else 0.0)])
            subpaths[-1].append(("L", cur, p))
        elif c == "Q":
            q, p = base + v[:2], base + v[2:]
            subpaths[-1].append(("Q", cur, q, p))
            last_ctrl = q
        elif c == "T":
            q = 2 * cur - last_ctrl if last_kind in "QT" and last_ctrl is not None else cur
            p = base + v
            subpaths[-1].append(("Q", cur, q, p))
            last_ctrl = q
        elif c == "C":
            c1, c2, p = base + v[:2], base + v[2:4], base + v[4:]
            subpaths[-1].append(("C", cur, c1, c2, p))
            last_ctrl = c2
        elif c == "S":
            c1 = 2 * cur - last_ctrl if last_kind in "CS" and last_ctrl is not None else cur
            c2, p = base + v[:2], base + v[2:]
            subpaths[-1].append(("C", cur, c1, c2, p))
            last_ctrl = c2
        last_kind = c
        cur = p
    return subpaths
