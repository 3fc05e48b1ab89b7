"""The workflow names the files its stages write in the Snakefile, where importing the package
would slow every DAG build (a rerun with nothing to do); these tests hold those names to the
package's own lists, so that a file added to a stage's output is declared in the workflow too."""
from __future__ import annotations

import ast
import re

from conftest import REPO


def _constant(name: str):
    """The value of a top-level tuple constant of workflow/rules/common.smk."""
    common = (REPO / "workflow" / "rules" / "common.smk").read_text()
    m = re.search(rf"^{name} = (\(.*?\))\n(?=\S|\n)", common, re.M | re.S)
    assert m, f"no constant {name} in common.smk"
    return ast.literal_eval(m.group(1))


def test_the_workflow_declares_every_file_a_diagnosis_writes():
    from roboball.diagnose.report import OUTPUT_FILES

    assert set(_constant("DIAGNOSIS_FILES")) == set(OUTPUT_FILES)
