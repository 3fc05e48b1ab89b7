"""`roboball stage NAME --param value ...`: run one pipeline stage (used by the Snakemake rules).

The stage's arguments are read off the function's signature: a parameter annotated `list`
takes several values; `float`/`int` are converted; everything else is a string.
"""
from __future__ import annotations

import argparse
import inspect

from roboball.cli.main import OneLineArgumentParser, register_command
from roboball.pipeline.codedeps import STAGE_MODULES   # one list: the CLI's search order and the rules' fingerprints


def _stages(wanted: str | None = None) -> dict:
    """Stage name -> function.  With `wanted`, import only the module that declares it (found in
    the stage table without importing anything), so a stage does not pay for importing the
    others (matplotlib, Drake); an unknown name imports them all to list the stages."""
    import importlib

    from roboball.pipeline.codedeps import stage_module
    out = {}
    try:                 # the module that declares the stage, found without importing the others
        modules = (stage_module(wanted),) if wanted is not None else STAGE_MODULES
    except KeyError:
        modules = STAGE_MODULES
    for name in modules:
        if wanted is not None and wanted in out:
            break
        try:
            mod = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name:
                continue
            raise
        for fname in getattr(mod, "STAGES", ()):
            out[fname.replace("_", "-")] = getattr(mod, fname)
    return out


def _run_stage(args) -> int:
    stages = _stages(args.stage)
    fn = stages.get(args.stage)
    if fn is None:
        from roboball.errors import RoboballError
        raise RoboballError(f"unknown stage '{args.stage}' (stages: {', '.join(sorted(stages))})")
    p = OneLineArgumentParser(prog=f"roboball stage {args.stage}", description=fn.__doc__)
    for name, par in inspect.signature(fn).parameters.items():
        ann = str(par.annotation)
        kw = {"required": par.default is inspect.Parameter.empty, "dest": name}
        if not kw["required"]:
            kw["default"] = par.default
        if "list" in ann:
            kw["nargs"] = "*"
        if ann.startswith("float"):
            kw["type"] = float
        elif ann.startswith("int"):
            kw["type"] = int
        p.add_argument("--" + name.replace("_", "-"), **kw)
    ns = p.parse_args(args.rest)
    fn(**vars(ns))
    return 0


@register_command
def _register(sub):
    s = sub.add_parser("stage", help="run one pipeline stage (called by the Snakemake rules)")
    s.add_argument("stage")
    s.add_argument("rest", nargs=argparse.REMAINDER)
    s.set_defaults(func=_run_stage)
