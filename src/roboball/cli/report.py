"""`roboball report --params`: the current parameter posteriors, shell regressions and PME
intervals as Markdown, rendered from existing results (roboball.report.params; nothing reruns)."""
from __future__ import annotations

from pathlib import Path

from roboball.cli.main import register_command
from roboball.errors import RoboballError


def cmd_report(args) -> int:
    if not args.params:
        raise RoboballError("report: say what to report (--params)")
    from roboball.report.params import render

    text = render(args.results, args.figures)
    if args.out:
        from roboball.atomic import write_text_atomic
        write_text_atomic(args.out, text)
        print(f"wrote {args.out}")
    else:
        print(text)
    return 0


@register_command
def _register(sub):
    r = sub.add_parser("report", help="render reports from existing results (no rerun)")
    r.add_argument("--params", action="store_true",
                   help="parameter posteriors, shell regressions and PME intervals as Markdown")
    r.add_argument("--results", type=Path, default=Path("results"), help="results folder (default results/)")
    r.add_argument("--figures", type=Path, default=Path("paper_figures"),
                   help="paper figures folder, for table_pme.csv (default paper_figures/)")
    r.add_argument("--out", type=Path, help="write the Markdown here (default: print it)")
    r.set_defaults(func=cmd_report)
