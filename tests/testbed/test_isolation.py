"""The analysis never sees the test bed's truth.

Nothing outside roboball.testbed may import it or read its config (truth.yaml); only the
test bed itself, the tests and the benchmarks (which play the experimenter) may."""
import ast
import subprocess
import sys

from conftest import REPO


def _analysis_sources():
    files = [p for p in (REPO / "src" / "roboball").rglob("*.py") if "testbed" not in p.relative_to(REPO / "src" / "roboball").parts]
    files += list((REPO / "workflow").rglob("*")) + [REPO / "Snakefile"]
    files += list((REPO / "configs").rglob("*"))
    return [p for p in files if p.is_file()]


def test_no_analysis_module_imports_the_testbed():
    offenders = []
    for path in _analysis_sources():
        text = path.read_text(encoding="utf-8", errors="replace")
        if "truth.yaml" in text or "TRUTH_YAML" in text:
            offenders.append(f"{path}: mentions the test bed's truth file")
        if path.suffix != ".py":
            if "roboball.testbed" in text or "roboball-testbed" in text:
                offenders.append(f"{path}: calls the test bed")
            continue
        for node in ast.walk(ast.parse(text)):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                mod = node.module or ""
                if node.level:   # relative import: resolve against the file's package
                    pkg = path.relative_to(REPO / "src").with_suffix("").parts[:-1]
                    base = pkg[: len(pkg) - node.level + 1]
                    mod = ".".join(base + ((mod,) if mod else ()))
                names = [mod] + [f"{mod}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) in ("import_module", "__import__"):
                names = [a.value for a in node.args if isinstance(a, ast.Constant) and isinstance(a.value, str)]
            if any(n == "roboball.testbed" or n.startswith("roboball.testbed.") for n in names):
                offenders.append(f"{path}:{node.lineno}: imports the test bed")
    assert not offenders, "\n".join(offenders)


def test_importing_every_analysis_module_leaves_testbed_unloaded():
    mods = sorted({".".join(p.relative_to(REPO / "src").with_suffix("").parts).removesuffix(".__init__")
                   for p in (REPO / "src" / "roboball").rglob("*.py")
                   if "testbed" not in p.parts})
    code = ("import importlib, sys\n"
            f"for m in {mods!r}:\n    importlib.import_module(m)\n"
            "import roboball.cli.main as c; c._load_plugins()\n"
            "bad = [m for m in sys.modules if m.startswith('roboball.testbed')]\n"
            "print(bad); sys.exit(1 if bad else 0)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_checker_catches_an_offender(tmp_path, monkeypatch):
    """The static check is not vacuous: a planted import is reported."""
    bad = REPO / "src" / "roboball" / "_planted_offender.py"
    bad.write_text("from .testbed import physics\n")
    try:
        try:
            test_no_analysis_module_imports_the_testbed()
        except AssertionError as exc:
            assert "_planted_offender.py" in str(exc)
        else:
            raise AssertionError("planted import not detected")
    finally:
        bad.unlink()
