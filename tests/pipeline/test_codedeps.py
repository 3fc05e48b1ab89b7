"""The rules' code fingerprints (roboball.pipeline.codedeps): a stage reruns when a source file it
runs, or the robot facts it reads, change, and not for an edit elsewhere in the package."""
import re
import shutil

import pytest

from roboball.pipeline import codedeps as C

from conftest import REPO


def _rules():
    """(rule name, stage it runs, the CODE key in its params) for every rule of the workflow."""
    out = []
    for smk in sorted((REPO / "workflow" / "rules").glob("*.smk")):
        for block in re.split(r"(?m)^[ \t]*(?=rule )", smk.read_text())[1:]:
            name = block.split()[1].rstrip(":")
            stage = re.search(r"\{ROBOBALL\} ([a-z0-9-]+)", block)
            code = re.search(r'code=CODE\["([a-z0-9-]+)"\]', block)
            out.append((name, stage and stage.group(1), code and code.group(1)))
    return out


def test_every_rule_carries_the_fingerprint_of_the_stage_it_runs():
    rules = _rules()
    assert len(rules) >= 20
    codes = C.stage_fingerprints(REPO / "configs")
    for name, stage, code in rules:
        assert stage is not None, f"rule {name} runs no roboball stage"
        assert code == stage, f"rule {name} runs '{stage}' but its params carry CODE[{code!r}]"
        assert stage in codes, f"rule {name}: no stage '{stage}' in {C.STAGE_MODULES}"


def test_closures_follow_imports_including_those_inside_functions():
    fit = C.closure(C.stage_module("friction-fit"))
    assert {"roboball.identify.friction.fit", "roboball.reduced.planar", "roboball.physics.friction",
            "roboball.config", "roboball.identify", "roboball"} <= set(fit)
    assert not any(m.startswith(("roboball.sim", "roboball.diagnose", "roboball.testbed")) for m in fit), fit
    # friction_figs imports the Drake scenarios inside a function (Fig. 7 simulates in Drake)
    assert "roboball.sim.scenarios" in C.closure(C.stage_module("fig-stand-fits"))
    assert "roboball.sim.scenarios" in C.closure(C.stage_module("ramp-sim"))
    with pytest.raises(KeyError, match="no pipeline stage named 'no-such'"):
        C.stage_module("no-such")


def test_editing_a_paper_figure_does_not_touch_the_stages_before_it():
    """The ingest stage draws a QC plot with the shared plotting module, not with the paper
    figures' module: an edit of Fig. 13 must not rerun ingest (and with it every job)."""
    figures = "roboball.figures.paper"
    for stage in ("ingest", "decay", "friction-fit", "ramp-sim", "diagnose-recording", "deflating-ramp", "table1"):
        assert figures not in C.closure(C.stage_module(stage)), stage
    assert "roboball.figures.style" in C.closure(C.stage_module("ingest"))
    assert figures in C.closure(C.stage_module("fig13-14"))


def test_fingerprints_change_with_what_the_stage_runs_and_nothing_else(tmp_path):
    root = tmp_path / "src" / "roboball"           # the checkout's layout: the lock file is at tmp_path
    shutil.copytree(C.PACKAGE_ROOT, root, ignore=shutil.ignore_patterns("__pycache__"))
    cfg = tmp_path / "configs"
    cfg.mkdir()
    shutil.copy2(REPO / "configs" / "robot.yaml", cfg / "robot.yaml")
    C.clear_caches()
    before = C.stage_fingerprints(cfg, root)
    assert before == C.stage_fingerprints(cfg, root)                   # deterministic

    law = root / "physics" / "friction.py"
    law.write_text(law.read_text() + "\n# an edit of the friction laws\n")
    C.clear_caches()
    after = C.stage_fingerprints(cfg, root)
    changed = {s for s in before if before[s] != after[s]}
    assert {"friction-fit", "ramp-sim", "shell-sim", "fig-stand-fits", "fig5"} <= changed, changed
    assert not changed & {"ingest", "decay", "shell-regression", "uncertainty-report", "fig10"}, changed

    fig = root / "report" / "uncertainty.py"
    fig.write_text(fig.read_text() + "\n# an edit of the report\n")
    C.clear_caches()
    again = C.stage_fingerprints(cfg, root)
    assert {s for s in after if after[s] != again[s]} == {"uncertainty-report"}

    (cfg / "robot.yaml").write_text((cfg / "robot.yaml").read_text().replace("ramp_angle_deg: 16.0", "ramp_angle_deg: 15.0"))
    facts = C.stage_fingerprints(cfg, root)
    refit = {s for s in again if again[s] != facts[s]}
    assert {"ramp-sim", "friction-fit", "table2", "fig10"} <= refit and "uncertainty-report" not in refit, refit

    # every stage: the runner that converts its arguments, and the pinned environment
    runner = root / "cli" / "stage.py"
    runner.write_text(runner.read_text() + "\n# an edit of the stage runner\n")
    C.clear_caches()
    run = C.stage_fingerprints(cfg, root)
    assert all(run[s] != facts[s] for s in facts)
    chain = C.source_fingerprint("roboball.identify.friction.fit", root)
    # the fingerprinting itself is bookkeeping: the friction fit imports it (for its chains'
    # identity), yet an edit of it reruns nothing and restarts no chain
    book = root / "pipeline" / "codedeps.py"
    book.write_text(book.read_text() + "\n# an edit of the bookkeeping\n")
    C.clear_caches()
    assert C.stage_fingerprints(cfg, root) == run
    assert C.source_fingerprint("roboball.identify.friction.fit", root) == chain
    (tmp_path / "requirements.lock").write_text("drake==1.51.1\n")
    C.clear_caches()
    locked = C.stage_fingerprints(cfg, root)
    assert all(locked[s] != run[s] for s in run)
    assert C.source_fingerprint("roboball.identify.friction.fit", root) != chain    # MCMC chains restart too
    C.clear_caches()


def test_the_cached_table_is_the_computed_one_until_any_byte_changes(tmp_path):
    """The DAG reuses the fingerprint table from .snakemake/ while no input byte changed (a run
    with nothing to do must not parse the package); an edit, robot.yaml included, recomputes it,
    and a torn cache file is recomputed rather than trusted."""
    root = tmp_path / "src" / "roboball"
    shutil.copytree(C.PACKAGE_ROOT, root, ignore=shutil.ignore_patterns("__pycache__"))
    cfg = tmp_path / "configs"
    cfg.mkdir()
    shutil.copy2(REPO / "configs" / "robot.yaml", cfg / "robot.yaml")
    cache = tmp_path / ".snakemake" / "codes.json"
    C.clear_caches()
    fresh = C.stage_fingerprints(cfg, root)
    assert C.stage_fingerprints(cfg, root, cache=cache) == fresh and cache.is_file()
    assert C.stage_fingerprints(cfg, root, cache=cache) == fresh           # read back

    law = root / "physics" / "friction.py"
    law.write_text(law.read_text() + "\n# an edit of the friction laws\n")
    C.clear_caches()
    edited = C.stage_fingerprints(cfg, root, cache=cache)
    assert edited == C.stage_fingerprints(cfg, root) and edited["friction-fit"] != fresh["friction-fit"]

    (cfg / "robot.yaml").write_text((cfg / "robot.yaml").read_text() + "\n# a comment\n")
    assert C.stage_fingerprints(cfg, root, cache=cache)["ramp-sim"] != edited["ramp-sim"]

    cache.write_text('{"key": "torn')
    C.clear_caches()
    assert C.stage_fingerprints(cfg, root, cache=cache) == C.stage_fingerprints(cfg, root)
    C.clear_caches()
