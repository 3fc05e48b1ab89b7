"""Every file the package writes goes to a temporary name in the same
folder and is renamed into place, so an interruption never leaves a half-written output.

* A static audit of src/roboball: every call that writes a file (savefig, to_csv, json.dump,
  write_text, open(..., "w"), h5py / emcee HDF5 backends) must go through roboball.atomic or sit
  in a function that renames a temporary file into place (os.replace).  The one exception is a
  resumable checkpoint that is never a result (the emcee chain of a friction fit, written in
  place step by step so that an interrupted fit resumes): its line must say so with a
  ``# checkpoint:`` comment, and its reader must recognise a foreign or damaged file.
* A recording and its sidecar are written as a pair: a crash between the two renames leaves a
  CSV without sidecar (refused), never new data next to the old sidecar.
"""
from __future__ import annotations

import ast
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roboball.atomic import savefig_atomic, write_texts_atomic
from roboball.ingest.errors import RecordingError
from roboball.ingest.recording import read_recording, write_recording

from conftest import REPO
SRC = REPO / "src" / "roboball"
WRITE_MODES = ("w", "wb", "a", "ab", "x", "xb", "w+", "r+", "a+")


def _mode(call: ast.Call, position: int) -> str | None:
    if len(call.args) > position and isinstance(call.args[position], ast.Constant):
        return call.args[position].value
    for k in call.keywords:
        if k.arg == "mode" and isinstance(k.value, ast.Constant):
            return k.value.value
    return None


def _memory_buffers(fn: ast.AST) -> set[str]:
    """Names bound to io.BytesIO()/StringIO() in a function (writing there is not writing a file)."""
    names = set()
    for node in ast.walk(fn):
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Call):
            f = node.value.func
            if (f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")) in ("BytesIO", "StringIO"):
                names |= {t.id for t in node.targets if isinstance(t, ast.Name)}
    return names


def non_atomic_writes(source: str, name: str = "<src>") -> list[str]:
    """File writes in `source` that are not made atomic (see module docstring)."""
    tree = ast.parse(source, name)
    lines = source.splitlines()
    found = []
    scopes = [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
    inner = {id(c) for fn in scopes for c in ast.walk(fn) if c is not fn}

    def check(scope, nodes):
        text = ast.unparse(scope) if not isinstance(scope, ast.Module) else ""
        renames = "os.replace(" in text or "atomic_write(" in text
        buffers = _memory_buffers(scope)
        for node in nodes:
            if not isinstance(node, ast.Call):
                continue
            f = node.func
            attr = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            first = node.args[0] if node.args else None
            to_buffer = isinstance(first, ast.Name) and first.id in buffers
            writes = (
                (attr in ("savefig", "to_csv", "to_json", "to_parquet", "to_hdf", "to_excel", "write_text",
                          "write_bytes") and first is not None and not to_buffer)
                or (attr == "dump" and isinstance(f, ast.Attribute) and getattr(f.value, "id", "") in ("json", "yaml",
                                                                                                        "pickle"))
                or (attr == "open" and _mode(node, 1) in WRITE_MODES)
                or (attr == "File" and _mode(node, 1) in WRITE_MODES)          # h5py.File(path, "w")
                or attr == "HDFBackend"                                         # emcee writes in place
                or (attr in ("save", "savez", "savez_compressed", "savetxt") and isinstance(f, ast.Attribute)
                    and getattr(f.value, "id", "") == "np")
            )
            declared = "# checkpoint:" in lines[node.lineno - 1]
            if writes and not renames and not declared:
                found.append(f"{name}:{node.lineno}: {ast.unparse(node)[:80]}")

    for fn in scopes:
        check(fn, list(ast.walk(fn)))
    module_level = [n for n in ast.walk(tree) if id(n) not in inner and not isinstance(n, ast.FunctionDef)]
    check(tree, module_level)
    return sorted(set(found))


def test_the_audit_finds_plain_writes():
    bad = ("import json\ndef f(df, fig, p):\n    df.to_csv(p)\n    fig.savefig(p)\n    json.dump({}, open(p, 'w'))\n"
           "    with h5py.File(p, 'w') as h: pass\n    b = emcee.backends.HDFBackend(p)\n    np.save(p, x)\n")
    assert len(non_atomic_writes(bad)) == 7, non_atomic_writes(bad)
    assert non_atomic_writes("def f(p):\n    b = emcee.backends.HDFBackend(p)  # checkpoint: resumable chain\n") == []
    good = ("def f(df, fig, p):\n    import io\n    buf = io.BytesIO()\n    fig.savefig(buf)\n"
            "    write_bytes_atomic(p, buf.getvalue())\n"
            "def g(fig, p):\n    tmp = p + '.tmp'\n    fig.savefig(tmp)\n    os.replace(tmp, p)\n"
            "def h(p):\n    with atomic_write(p) as fh:\n        fh.write('x')\n    open(p).read()\n")
    assert non_atomic_writes(good) == []


def test_every_writer_in_the_package_is_atomic():
    found = []
    for path in sorted(SRC.rglob("*.py")):
        if path.name == "atomic.py":
            continue
        found += non_atomic_writes(path.read_text(encoding="utf-8"), str(path.relative_to(REPO)))
    assert not found, "write these through roboball.atomic (temp name + os.replace):\n" + "\n".join(found)


# --------------------------------------------------------------------------------------------
# a recording and its sidecar
# --------------------------------------------------------------------------------------------
def _rec(p_kpa: float, n: int = 50):
    t = np.arange(n) * 0.01
    return pd.DataFrame({"time_s": t, "pipe_angle_rad": 0.1 * np.cos(3 * t)}), {"kind": "shell_rock", "pressure_kpa": p_kpa}


def test_crash_between_the_renames_never_pairs_new_data_with_an_old_sidecar(tmp_path, monkeypatch):
    path = tmp_path / "run.csv"
    write_recording(path, *_rec(13.8))
    real_replace = os.replace
    calls = []

    def crash_on_second(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise KeyboardInterrupt("killed between the renames")
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", crash_on_second)
    with pytest.raises(KeyboardInterrupt):
        write_recording(path, *_rec(6.9, n=80))
    monkeypatch.setattr(os, "replace", real_replace)
    # The new CSV is in place, the old sidecar (13.8 kPa) is gone: the reader refuses the file
    # instead of reading 80 new samples as a 13.8 kPa run.
    assert len(path.read_text().splitlines()) == 81
    with pytest.raises(RecordingError, match="sidecar run.json: missing"):
        read_recording(path)
    assert [p.name for p in tmp_path.iterdir()] == ["run.csv"], "temporary files left behind"
    write_recording(path, *_rec(6.9, n=80))                 # the rerun repairs it
    assert read_recording(path).pressure_kpa == 6.9


def test_failure_while_staging_changes_nothing(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    write_texts_atomic([(a, "old a\n"), (b, "old b\n")])

    with pytest.raises(TypeError):           # the second content cannot be written
        write_texts_atomic([(a, "new a\n"), (b, None)])
    assert a.read_text() == "old a\n" and b.read_text() == "old b\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt"]


def test_savefig_atomic_writes_whole_figures_only(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    png = savefig_atomic(fig, tmp_path / "f.png", dpi=50)
    pdf = savefig_atomic(fig, tmp_path / "f.pdf")
    assert png.read_bytes()[:4] == b"\x89PNG" and pdf.read_bytes()[:4] == b"%PDF"
    with pytest.raises(ValueError):                       # matplotlib refuses the format
        savefig_atomic(fig, tmp_path / "g.png", format="no-such-format")
    plt.close(fig)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.pdf", "f.png"]


def test_pipeline_figures_go_through_scratch_files_named_tmp(tmp_path, monkeypatch):
    """A run killed mid-save may leave a scratch file; it must read as scratch (*.tmp), never as a
    hidden figure (the kill-and-resume test found `.fig.png.x1y2.png` left by the old saver)."""
    import matplotlib.pyplot as plt

    from roboball.figures import style as plotting

    real_replace, scratch = os.replace, []
    monkeypatch.setattr(os, "replace", lambda src, dst: (scratch.append(Path(src).name), real_replace(src, dst)))
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    plotting.save(fig, tmp_path / "fig99_test.png")
    assert len(scratch) == 2 and all(n.startswith(".fig99_test.") and n.endswith(".tmp") for n in scratch), scratch
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig99_test.pdf", "fig99_test.png"]
    assert (tmp_path / "fig99_test.pdf").read_bytes()[:4] == b"%PDF"


def test_a_folder_where_a_file_should_go_is_refused_naming_it(tmp_path):
    """The rename would fail naming the scratch file; the writers name the path given instead,
    and stage nothing."""
    from roboball.atomic import write_text_atomic, write_texts_atomic

    folder = tmp_path / "out.csv"
    folder.mkdir()
    for write in (lambda: write_text_atomic(folder, "x"), lambda: write_texts_atomic([(tmp_path / "a.csv", "a"), (folder, "b")])):
        with pytest.raises(IsADirectoryError) as err:
            write()
        assert err.value.filename == str(folder) and "is a folder" in err.value.strerror
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"] and not any(folder.iterdir())
