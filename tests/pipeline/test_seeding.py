"""Every random draw of the pipeline is seeded from the config.

Static checks over the package and the workflow (cheap, and they fail as soon as someone adds an
unseeded draw): no NumPy global-state draws, no `default_rng()` without a seed, no stdlib
`random`, scipy `rvs` only with `random_state`, emcee samplers only with their random state
set; and every pipeline stage that takes a `seed` gets it from `config["seed"]` in its rule.
The dynamic check (two clean runs, byte-identical outputs) is in test_reliability_pipeline.py.
"""
from __future__ import annotations

import ast
import inspect
import re

import pytest

from conftest import REPO
SRC = REPO / "src" / "roboball"
# np.random attributes that do not draw from the hidden global state
SEEDABLE = {"default_rng", "Generator", "SeedSequence", "RandomState", "PCG64", "PCG64DXSM", "Philox",
            "SFC64", "MT19937", "BitGenerator", "mtrand"}   # mtrand: the module holding RandomState


def unseeded_draws(source: str, name: str = "<src>") -> list[str]:
    """Places in `source` that draw random numbers without an explicit seed."""
    tree = ast.parse(source, name)
    found = []
    for node in ast.walk(tree):
        where = f"{name}:{getattr(node, 'lineno', '?')}"
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            mods = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
            if any(m == "random" or m.startswith("random.") for m in mods):
                found.append(f"{where}: stdlib random (use a seeded numpy Generator)")
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute) \
                and node.value.attr == "random" and node.attr not in SEEDABLE:
            found.append(f"{where}: np.random.{node.attr} uses the global random state")
        if isinstance(node, ast.Call):
            fn = node.func
            fname = fn.attr if isinstance(fn, ast.Attribute) else fn.id if isinstance(fn, ast.Name) else ""
            no_seed = not node.args or (isinstance(node.args[0], ast.Constant) and node.args[0].value is None)
            if fname in ("default_rng", "RandomState") and no_seed and not any(k.arg == "seed" for k in node.keywords):
                found.append(f"{where}: {fname}() without a seed")
            if fname == "rvs" and not any(k.arg == "random_state" for k in node.keywords):
                found.append(f"{where}: .rvs() without random_state")
    if "EnsembleSampler(" in source and "random_state" not in source and "._random = " not in source:
        found.append(f"{name}: emcee.EnsembleSampler without setting its random_state (it would copy "
                     "NumPy's global state)")
    return found


def test_the_detector_finds_unseeded_draws():
    """The scan itself must work, or the test below proves nothing."""
    bad = ("import random\nimport numpy as np\nx = np.random.normal(0, 1)\nrng = np.random.default_rng()\n"
           "from scipy import stats\ny = stats.norm.rvs(size=3)\nimport emcee\ns = emcee.EnsembleSampler(8, 2, f)\n")
    found = unseeded_draws(bad)
    assert len(found) == 5, found
    good = ("import numpy as np\nrng = np.random.default_rng(seed)\nss = np.random.SeedSequence([1, 2])\n"
            "g = np.random.Generator(np.random.PCG64(ss))\ny = stats.norm.rvs(size=3, random_state=rng)\n"
            "s = emcee.EnsembleSampler(8, 2, f)\ns.random_state = np.random.RandomState(seed).get_state()\n")
    assert unseeded_draws(good) == []


def test_no_unseeded_random_draws_in_the_package():
    found = []
    for path in sorted(SRC.rglob("*.py")):
        found += unseeded_draws(path.read_text(encoding="utf-8"), str(path.relative_to(REPO)))
    assert not found, "\n".join(found)


def _rule_blocks() -> dict[str, str]:
    blocks = {}
    for smk in sorted((REPO / "workflow" / "rules").glob("*.smk")):
        parts = re.split(r"^[ \t]*rule (\w+):", smk.read_text(), flags=re.M)     # rules under an `if` too
        for name, body in zip(parts[1::2], parts[2::2]):
            blocks[name] = body
    return blocks


def test_every_seeded_stage_gets_its_seed_from_the_config():
    from roboball.cli.stage import _stages

    stages = _stages()
    seeded = {name for name, fn in stages.items() if "seed" in inspect.signature(fn).parameters}
    if not seeded:
        pytest.skip("no pipeline stage draws random numbers")
    blocks = _rule_blocks()
    for stage in sorted(seeded):
        calls = {rule: body for rule, body in blocks.items() if re.search(r"\{ROBOBALL\} " + re.escape(stage) + r"\b", body)}
        for rule, body in calls.items():
            each = re.search(r"each=(get_\w+)", body)
            if each:               # a batched rule: its items' arguments come from an input function
                body = _function_source(each.group(1))
                assert '"seed": config["seed"]' in body, f"rule {rule}: {each.group(1)} gives stage {stage} no seed from config['seed']"
                continue
            assert "--seed" in body, f"rule {rule} runs stage {stage} without --seed"
            assert 'config["seed"]' in body, f"rule {rule}: the seed of stage {stage} must derive from config['seed']"


def _function_source(name: str) -> str:
    """The source of an input function of workflow/rules/common.smk, up to the next definition."""
    common = (REPO / "workflow" / "rules" / "common.smk").read_text()
    m = re.search(rf"^def {name}\(.*?(?=^def |^#####|\Z)", common, re.M | re.S)
    assert m, f"no input function {name} in common.smk"
    return m.group(0)
