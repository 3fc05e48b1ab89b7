"""Design: when a diagnosis cannot decide, which recording would (issue 47).

    from roboball.design import design
    src, js = design("results/diagnose/real_steer_stand", out_dir="results/design/real_steer_stand")

For each undecided choice of a diagnosis (an effect and its listed alternatives, the steer
setting of a shell release, a poorly pinned parameter: roboball.design.inputs), every candidate
is simulated by the diagnosis's own reduced models and engine over the experiments the rig can
run for that kind (roboball.design.experiments: release angle, two releases in one recording, a
longer settle, the shell's steer clamp; roboball.design.ramp: the ramp's angle), with its
parameters' uncertainty carried through, and the experiments are ranked by how clearly the candidates would differ in a recording like the
user's (roboball.design.rank: the expected chi^2 gap against the log's own noise, and the
separation in noise levels).  roboball.design.output writes design.json, design.md and the
figure; the command is roboball.cli.design.
"""
from __future__ import annotations


def design(folder, out_dir=None, log=None):
    """Design the next recording for the diagnosis in `folder`.  Returns (Source, design.json
    content); with `out_dir`, writes design.json, design.md and design.png there."""
    from roboball.design.inputs import read_source
    from roboball.design.plan import plan

    src = read_source(folder)
    if log:
        log(f"{len(src.choices)} undecided choice(s): " + "; ".join(c.name for c in src.choices))
    js, grids = plan(src, log=log)
    if out_dir is not None:
        from roboball.design.output import write
        write(src, js, grids, out_dir)
    return src, js
