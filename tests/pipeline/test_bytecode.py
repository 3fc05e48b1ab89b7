"""The workflow compiles the package once per run (roboball.pipeline.bytecode), so that jobs
load its modules rather than recompile them where PYTHONDONTWRITEBYTECODE is set."""
import importlib.util
import os
import shutil

import pytest

from roboball.pipeline.bytecode import PACKAGE_ROOT, compile_package


def test_every_module_gets_a_current_cache_and_only_an_edited_one_is_rewritten(tmp_path):
    root = tmp_path / "roboball"
    shutil.copytree(PACKAGE_ROOT / "physics", root, ignore=shutil.ignore_patterns("__pycache__"))
    assert compile_package(root)
    sources = sorted(root.rglob("*.py"))
    caches = {f: importlib.util.cache_from_source(str(f)) for f in sources}
    assert sources and all(os.path.isfile(c) for c in caches.values())
    stamps = {f: os.stat(c).st_mtime_ns for f, c in caches.items()}

    edited = sources[0]
    edited.write_text(edited.read_text() + "\n# an edit\n")
    os.utime(edited, ns=(stamps[edited] + 10**9, stamps[edited] + 10**9))   # newer than its cache
    assert compile_package(root)
    rewritten = {f for f, c in caches.items() if os.stat(c).st_mtime_ns != stamps[f]}
    assert rewritten == {edited}


def test_a_folder_that_cannot_be_written_is_left_to_compile_in_memory(tmp_path):
    root = tmp_path / "roboball"
    root.mkdir()
    (root / "m.py").write_text("x = 1\n")
    os.chmod(root, 0o555)
    try:
        if os.access(root, os.W_OK):
            pytest.skip("running as root: the folder stays writable")
        assert compile_package(root) is False
    finally:
        os.chmod(root, 0o755)
