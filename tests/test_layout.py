"""The package reads as the pipeline (docs/layout.md): each folder of src/roboball is a room with
one job, and a room imports only the rooms below it, so there is no import cycle; no module is
longer than 500 lines and no function longer than a screen.  Read from the sources (ast), so a
function-level import counts as much as a top-level one."""
import ast
from collections import defaultdict
from pathlib import Path

from conftest import REPO

SRC = REPO / "src"
PACKAGE = SRC / "roboball"
MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 60

# Each room and the rooms it may import (besides itself).  Leaves first, the command line last;
# the test bed stands beside the analysis and only the tests and benchmarks may import it.
LEAVES = {"errors", "atomic", "kinds", "metrics", "config", "physics"}
ALLOWED = {
    "errors": set(), "atomic": set(), "kinds": set(), "physics": set(),
    "metrics": set(), "config": {"errors"},
    "checks": LEAVES,
    "ingest": LEAVES,
    "sim": LEAVES,
    "reduced": LEAVES | {"sim"},
    "identify": LEAVES | {"checks", "ingest", "reduced"},
    "diagnose": LEAVES | {"ingest", "sim", "reduced", "identify"},
    "design": LEAVES | {"ingest", "sim", "reduced", "identify", "diagnose"},
    "figures": LEAVES | {"ingest", "sim", "identify"},
    "report": LEAVES | {"identify"},
    "pipeline": LEAVES | {"checks", "ingest", "sim", "reduced", "identify", "diagnose", "figures", "report"},
    "cli": LEAVES | {"checks", "ingest", "sim", "reduced", "identify", "diagnose", "design", "figures", "report",
                     "pipeline"},
    "testbed": LEAVES | {"ingest", "sim"},
}


def _modules(src: Path = SRC) -> dict[str, Path]:
    out = {}
    for f in (src / "roboball").rglob("*.py"):
        parts = list(f.relative_to(src).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = f
    return out


def _imports(modules: dict[str, Path]) -> dict[str, set[str]]:
    """roboball module -> the roboball modules it imports anywhere in its file."""
    graph = defaultdict(set)
    for name, f in modules.items():
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            for t in targets:
                while t not in modules and "." in t:
                    t = t.rpartition(".")[0]
                if t in modules and t != name and t != "roboball":
                    graph[name].add(t)
    return graph


def _room(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "roboball"


def test_every_room_is_in_the_table():
    rooms = {_room(m) for m in _modules()} - {"roboball"}
    assert rooms == set(ALLOWED), f"rooms not in the layout table: {rooms - set(ALLOWED)}; " \
                                  f"gone: {set(ALLOWED) - rooms}"


def _wrong_way(src: Path = SRC) -> list[str]:
    return sorted(f"{a} imports {b}" for a, targets in _imports(_modules(src)).items() for b in targets
                  if _room(b) != _room(a) and _room(b) not in ALLOWED[_room(a)])


def _cycles(src: Path = SRC) -> list[list[str]]:
    graph = _imports(_modules(src))
    index, low, stack, on, cycles, counter = {}, {}, [], set(), [], [0]

    def visit(v):     # Tarjan's strongly connected components
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in list(_modules(src)):
        if v not in index:
            visit(v)
    return cycles


def test_no_room_imports_a_room_above_it():
    bad = _wrong_way()
    assert not bad, "\n".join(bad)


def test_no_import_cycle():
    cycles = _cycles()
    assert not cycles, cycles


def test_the_checks_see_a_planted_offence(tmp_path):
    """A wrong-way import inside a function and a two-module cycle are both caught."""
    pkg = tmp_path / "roboball"
    for room in ("ingest", "diagnose"):
        (pkg / room).mkdir(parents=True)
        (pkg / room / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "ingest" / "a.py").write_text("def f():\n    from roboball.diagnose.b import g\n")
    (pkg / "diagnose" / "b.py").write_text("from roboball.ingest import a\n\ndef g():\n    pass\n")
    assert _wrong_way(tmp_path) == ["roboball.ingest.a imports roboball.diagnose.b"]
    assert _cycles(tmp_path) == [["roboball.diagnose.b", "roboball.ingest.a"]]


def test_no_module_over_500_lines():
    long = {str(f.relative_to(SRC)): n for f in PACKAGE.rglob("*.py")
            if (n := len(f.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES}
    assert not long, long


def test_every_function_fits_on_a_screen():
    long = []
    for f in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long.append(f"{f.relative_to(SRC)}:{node.lineno} {node.name} ({n} lines)")
    assert not long, "\n".join(long)
