"""The pipeline's own Markdown tables (paper_figures/table*.md) as HTML: headings, paragraphs,
pipe tables, **bold** and `code`, which is all roboball writes.  Not a general Markdown
renderer: anything else stays plain (escaped) text.
"""
from __future__ import annotations

import html
import re

_NUMBER = re.compile(r"^[+-]?\d+(\.\d+)?$")


def inline(text: str) -> str:
    """Escape `text` and render its **bold** and `code` spans."""
    out = html.escape(text.replace("\\|", "|"), quote=False)
    out = re.sub(r"`([^`]+)`", r"<code>\1</code>", out)
    return re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", out)


def _cells(line: str) -> list:
    """A pipe-table row's cells (a backslash-escaped pipe stays inside its cell)."""
    parts = re.split(r"(?<!\\)\|", line.strip())
    return [p.strip() for p in parts[1:-1]]


def _table(lines: list) -> str:
    head = "".join(f"<th>{inline(c)}</th>" for c in _cells(lines[0]))
    rows = []
    for line in lines[2:]:
        cells = "".join(f"<td class='num'>{inline(c)}</td>" if _NUMBER.match(c) else f"<td>{inline(c)}</td>"
                        for c in _cells(line))
        rows.append(f"<tr>{cells}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def blocks(md: str) -> list:
    """The Markdown as (kind, html) blocks, kind one of "h1".."h4", "p", "table"."""
    out, para, lines = [], [], md.splitlines()
    i = 0

    def flush():
        if para:
            out.append(("p", inline(" ".join(para))))
            para.clear()

    while i < len(lines):
        line = lines[i].rstrip()
        if line.startswith("|") and i + 1 < len(lines) and re.match(r"^\|[\s:|-]+\|$", lines[i + 1].strip()):
            flush()
            j = i
            while j < len(lines) and lines[j].strip().startswith("|"):
                j += 1
            out.append(("table", _table(lines[i:j])))
            i = j
            continue
        m = re.match(r"^(#{1,4})\s+(.*)$", line)
        if m:
            flush()
            out.append((f"h{len(m.group(1))}", inline(m.group(2))))
        elif not line.strip():
            flush()
        else:
            para.append(line.strip())
        i += 1
    flush()
    return out


def to_html(md: str, shift: int = 0) -> str:
    """The Markdown as HTML, its headings `shift` levels lower (a table's "#" title inside a
    report's section)."""
    parts = []
    for kind, text in blocks(md):
        if kind.startswith("h"):
            level = min(int(kind[1]) + shift, 6)
            parts.append(f"<h{level}>{text}</h{level}>")
        elif kind == "p":
            parts.append(f"<p>{text}</p>")
        else:
            parts.append(text)
    return "\n".join(parts)
