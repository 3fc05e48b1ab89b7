"""What a pipeline stage's result depends on besides its data: the package's source files it
runs (its module and every roboball module that module imports, directly or inside a function,
transitively, and the stage runner roboball.cli.stage), when those read the robot facts
`configs/robot.yaml`, and the pinned environment `requirements.lock`.

The Snakemake rules put `stage_fingerprint(stage)` in their params, so an edit of a friction law
reruns the fits and simulations that use it, an edit of a figure module reruns only its figures,
and an edit of the robot facts reruns everything derived from them.  A `touch` that changes no
byte reruns nothing.  Read with the standard library only (ast, hashlib): building the DAG stays
fast and imports neither Drake nor matplotlib.
"""
from __future__ import annotations

import ast
import hashlib
import json
import os
from functools import lru_cache
from pathlib import Path

PACKAGE_ROOT = Path(__file__).resolve().parents[1]        # .../src/roboball
PACKAGE = "roboball"
# The stage modules, in the order `roboball stage` searches them (roboball.cli.stage).
STAGE_MODULES = ("roboball.pipeline.ident", "roboball.pipeline.replays", "roboball.pipeline.simulation",
                 "roboball.figures.paper", "roboball.figures.friction", "roboball.report.uncertainty",
                 "roboball.report.tables", "roboball.pipeline.friction", "roboball.pipeline.deflating",
                 "roboball.pipeline.diagnosis", "roboball.pipeline.coupled", "roboball.pipeline.hydro",
                 "roboball.figures.hydro")
ROBOT_FACTS_READER = "roboball.config"
# Run by every stage besides its own closure: the runner that turns `roboball stage NAME --arg`
# into the call (only its own file: its imports are the CLI's, not the stage's).
STAGE_RUNNER = "roboball.cli.stage"
# The numeric code paths every job runs on (set by the workflow, not imported by the stages): a
# change of them changes every result.
NUMERICS = "roboball.pipeline.numerics"
# The pinned environment (drake, numpy, emcee, ...): an upgrade can change any number.
LOCK_FILE = "requirements.lock"
# Bookkeeping that computes fingerprints and changes no result: importing it (the friction-
# fit stage does, to fingerprint its MCMC chains) makes no module depend on it.
BOOKKEEPING = frozenset({"roboball.pipeline.codedeps"})


def module_file(module: str, root: Path = PACKAGE_ROOT) -> Path | None:
    """The file of a roboball module (a package's __init__.py), or None if there is none."""
    parts = module.split(".")
    if parts[0] != PACKAGE:
        return None
    base = root.joinpath(*parts[1:])
    for f in (base.with_suffix(".py"), base / "__init__.py"):
        if f.is_file():
            return f
    return None


@lru_cache(maxsize=None)
def _imports(module: str, root: Path) -> tuple[str, ...]:
    """roboball modules that `module` imports anywhere in its file (top level or in functions),
    with the packages on the way (importing a.b.c runs a/__init__ and a/b/__init__)."""
    f = module_file(module, root)
    if f is None:
        return ()
    tree = ast.parse(f.read_text(encoding="utf-8"), filename=str(f))
    package = module if f.name == "__init__.py" else module.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.split(".")[0] == PACKAGE)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != PACKAGE:
                continue
            found.add(target)
            for a in node.names:                      # `from .. import reduced`: a submodule
                if module_file(f"{target}.{a.name}", root) is not None:
                    found.add(f"{target}.{a.name}")
    with_parents = set()
    for m in found - BOOKKEEPING:
        parts = m.split(".")
        with_parents.update(".".join(parts[:k]) for k in range(1, len(parts) + 1))
    return tuple(sorted(m for m in with_parents if module_file(m, root) is not None))


def closure(module: str, root: Path = PACKAGE_ROOT) -> list[str]:
    """`module` and every roboball module it imports, transitively, sorted."""
    parts = module.split(".")
    seen, todo = set(), [".".join(parts[:k]) for k in range(1, len(parts) + 1)]
    while todo:
        m = todo.pop()
        if m in seen:
            continue
        seen.add(m)
        todo.extend(_imports(m, root))
    return sorted(m for m in seen if module_file(m, root) is not None)


@lru_cache(maxsize=None)
def _stage_table(root: Path = PACKAGE_ROOT) -> dict[str, str]:
    """Stage name (with -) -> the stage module that declares it in its STAGES tuple."""
    table: dict[str, str] = {}
    for mod in STAGE_MODULES:
        f = module_file(mod, root)
        if f is None:
            continue
        for node in ast.parse(f.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "STAGES" for t in node.targets):
                for name in ast.literal_eval(node.value):
                    table.setdefault(name.replace("_", "-"), mod)
    return table


def clear_caches() -> None:
    """Forget parsed imports and stage tables (after editing the sources in the same process)."""
    _imports.cache_clear()
    _stage_table.cache_clear()


def stage_module(stage: str, root: Path = PACKAGE_ROOT) -> str:
    """The module that defines `stage` (the name of `roboball stage NAME`, - or _)."""
    try:
        return _stage_table(root)[stage.replace("_", "-")]
    except KeyError:
        raise KeyError(f"no pipeline stage named '{stage}' (stage modules: {', '.join(STAGE_MODULES)})") from None


def _fingerprint(modules: list[str], sources: dict[str, bytes], config_dir: Path, root: Path) -> str:
    """Hash of the modules' sources (each file read once into `sources`), plus robot.yaml when
    the modules include the robot facts' reader, plus the environment's lock file (beside the
    package's src/ folder) when there is one."""
    h = hashlib.sha256()
    files = [(m, m) for m in modules] + ([("robot.yaml", None)] if ROBOT_FACTS_READER in modules else [])
    for name, m in files:
        if name not in sources:
            sources[name] = (module_file(m, root) if m else config_dir / "robot.yaml").read_bytes()
        h.update(name.encode() + b"\0" + sources[name] + b"\0")
    lock = root.parent.parent / LOCK_FILE
    if LOCK_FILE not in sources:
        sources[LOCK_FILE] = lock.read_bytes() if lock.is_file() else b""
    h.update(LOCK_FILE.encode() + b"\0" + sources[LOCK_FILE] + b"\0")
    return h.hexdigest()[:16]


def source_fingerprint(module: str, root: Path = PACKAGE_ROOT) -> str:
    """A short hash of the source files `module` runs (its import closure), without any config:
    the identity of a computation's code, for results cached outside Snakemake (MCMC chains)."""
    return _fingerprint([m for m in closure(module, root) if m != ROBOT_FACTS_READER] + [NUMERICS], {}, Path("."),
                        root)


def _stage_modules(module: str, root: Path) -> list[str]:
    """What a stage defined in `module` runs: its closure and the stage runner."""
    return sorted(set(closure(module, root)) | {STAGE_RUNNER, NUMERICS})


def stage_fingerprint(stage: str, config_dir: str | Path = "configs", root: Path = PACKAGE_ROOT) -> str:
    """A short hash of the stage's source files (and of robot.yaml when it reads the robot facts)."""
    return _fingerprint(_stage_modules(stage_module(stage, root), root), {}, Path(config_dir), root)


def _compute_fingerprints(config_dir: Path, root: Path) -> dict[str, str]:
    sources: dict[str, bytes] = {}
    closures = {mod: _stage_modules(mod, root) for mod in set(_stage_table(root).values())}
    return {stage: _fingerprint(closures[mod], sources, Path(config_dir), root)
            for stage, mod in _stage_table(root).items()}


def _inputs_key(config_dir: Path, root: Path) -> str:
    """A hash of every byte the fingerprints can depend on: the package's source files (names
    and contents), robot.yaml and the lock file.  Reading and hashing them takes milliseconds;
    parsing them (what the fingerprints need) takes a third of a second."""
    h = hashlib.sha256()
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
        for name in sorted(filenames):
            if name.endswith(".py"):
                f = Path(dirpath, name)
                h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes() + b"\0")
    for f in (Path(config_dir) / "robot.yaml", root.parent.parent / LOCK_FILE):
        h.update(f.name.encode() + b"\0" + (f.read_bytes() if f.is_file() else b"") + b"\0")
    return h.hexdigest()


def stage_fingerprints(config_dir: str | Path = "configs", root: Path = PACKAGE_ROOT,
                       cache: str | Path | None = None) -> dict[str, str]:
    """Stage name (with -) -> fingerprint, for every stage of every stage module (each source
    file read once; computed while Snakemake builds the DAG).

    With `cache` (a JSON file, e.g. in .snakemake/), the table is reused while no byte of its
    inputs changed, so a run with nothing to do does not parse the package again; any edit,
    even one that keeps a file's size and time, changes the key and recomputes it."""
    if cache is None:
        return _compute_fingerprints(Path(config_dir), root)
    cache = Path(cache)
    key = _inputs_key(Path(config_dir), root)
    try:
        stored = json.loads(cache.read_text(encoding="utf-8"))
        if stored.get("key") == key and isinstance(stored.get("fingerprints"), dict):
            return stored["fingerprints"]
    except (OSError, ValueError):
        pass                       # missing or torn cache: recompute
    table = _compute_fingerprints(Path(config_dir), root)
    cache.parent.mkdir(parents=True, exist_ok=True)
    tmp = cache.with_name(f"{cache.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps({"key": key, "fingerprints": table}, sort_keys=True), encoding="utf-8")
    os.replace(tmp, cache)         # atomic: two runs never read half a file
    return table
