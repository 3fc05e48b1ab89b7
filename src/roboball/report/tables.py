"""The paper's tables (paper_figures/table*.md) as HTML pages, for the Snakemake report, which
shows an HTML result in place and a Markdown one only as text."""
from __future__ import annotations

import re
from pathlib import Path

from roboball.atomic import write_text_atomic
from roboball.report import markdown
from roboball.report.uncertainty_page import CSS, TABLE_PAGE

STAGES = ("table_page",)


def table_page(md: str, out_html: str) -> None:
    """One of the paper's Markdown tables as an HTML page, titled by its first heading."""
    text = Path(md).read_text(encoding="utf-8")
    title = next((t for k, t in markdown.blocks(text) if k == "h1"), Path(md).stem)
    write_text_atomic(out_html, TABLE_PAGE.render(css=CSS, title=re.sub("<[^>]+>", "", title),
                                                  body=markdown.to_html(text), source=Path(md).name))
