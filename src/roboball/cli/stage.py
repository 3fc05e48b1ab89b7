"""`roboball stage NAME --param value ...`: run one pipeline stage (used by the Snakemake rules).

The stage's arguments are read off the function's signature: a parameter annotated `list`
takes several values; `float`/`int` are converted; everything else is a string.

`roboball stage NAME --each JSON` runs the stage once per item of a JSON list of {param: value}
objects, in one process: the rules batch their seconds-long jobs this way (a job's start-up,
Python with NumPy, pandas, SciPy and Drake, costs about as much as one of its simulations).  Each
item goes through the same argument parser as a single call, and runs the same function.
"""
from __future__ import annotations

import argparse
import inspect
import json
import sys

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


def _parser(stage: str, fn) -> OneLineArgumentParser:
    p = OneLineArgumentParser(prog=f"roboball stage {stage}", description=fn.__doc__)
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
    return p


def _item_argv(stage: str, k: int, item) -> list[str]:
    """The command line of one `--each` item: {param: value or [values]} -> ["--param", "value", ...]."""
    from roboball.errors import RoboballError
    if not isinstance(item, dict):
        raise RoboballError(f"roboball stage {stage} --each: item {k} is not an object of parameters")
    argv = []
    for name, value in item.items():
        values = value if isinstance(value, list) else [value]
        if any(isinstance(v, (dict, list)) for v in values):
            raise RoboballError(f"roboball stage {stage} --each: item {k}, field '{name}': not a value or a list of values")
        argv += ["--" + name.replace("_", "-")] + [v if isinstance(v, str) else json.dumps(v) for v in values]
    return argv


def _run_each(stage: str, fn, p: OneLineArgumentParser, rest: list[str]) -> None:
    """`--each JSON`: parse every item, then run them in order in this process."""
    from roboball.errors import RoboballError
    if len(rest) != 2:
        raise RoboballError(f"roboball stage {stage} --each takes one JSON list and nothing else")
    try:
        items = json.loads(rest[1])
    except ValueError as exc:
        raise RoboballError(f"roboball stage {stage} --each: not JSON ({exc})") from None
    if not isinstance(items, list):
        raise RoboballError(f"roboball stage {stage} --each: not a JSON list")
    calls = []
    for k, item in enumerate(items, start=1):          # a bad item is named before any item runs
        p.prog = f"roboball stage {stage} --each (item {k})"
        calls.append(vars(p.parse_args(_item_argv(stage, k, item))))
    for k, call in enumerate(calls, start=1):
        print(f"roboball stage {stage}: item {k} of {len(calls)}", file=sys.stderr, flush=True)
        fn(**call)


def _run_stage(args) -> int:
    stages = _stages(args.stage)
    fn = stages.get(args.stage)
    if fn is None:
        from roboball.errors import RoboballError
        raise RoboballError(f"unknown stage '{args.stage}' (stages: {', '.join(sorted(stages))})")
    p = _parser(args.stage, fn)
    if args.rest[:1] == ["--each"]:
        _run_each(args.stage, fn, p, args.rest)
    else:
        fn(**vars(p.parse_args(args.rest)))
    return 0


@register_command
def _register(sub):
    s = sub.add_parser("stage", help="run one pipeline stage (called by the Snakemake rules)")
    s.add_argument("stage")
    s.add_argument("rest", nargs=argparse.REMAINDER)
    s.set_defaults(func=_run_stage)
