"""`roboball design DIAGNOSIS_DIR [--out DIR]`: when a diagnosis cannot decide between
explanations, which recording would (roboball.design).  Writes DIR/design.json, DIR/design.md
and DIR/design.png (default DIR: DIAGNOSIS_DIR/design).  Exit 0 when a design was made (also
when nothing was undecided, or no experiment separates the candidates: design.md says so); a
one-line error and a non-zero exit on bad input (no diagnosis.json, a recording gone, ...)."""
from __future__ import annotations

import time
from pathlib import Path

from roboball.cli.main import register_command


def cmd_design(args) -> int:
    from roboball.atomic import output_folder
    from roboball.design import design
    from roboball.design.output import OUTPUT_FILES

    t0 = time.perf_counter()
    out = Path(args.out) if args.out else Path(args.diagnosis) / "design"
    output_folder(out, create=False, files=OUTPUT_FILES)     # refused before any work
    _, js = design(args.diagnosis, out_dir=out)
    for c in js["choices"]:
        b = c["best"]
        if b is None:
            print(f"{c['choice']}: no feasible experiment")
            continue
        verdict = "settles it" if c["settled"] else f"does not settle it; would: {c['sensor']}"
        if b["kind"] == "ramp":
            what = f"a descent on a ramp of {b['ramp_angle_deg']:g} deg ({b['recording_s']:.1f} s)"
        else:
            rel = ", ".join(f"{x:+.2f}" for x in b["release_from_rest_rad"])
            joint = f", steer joint {b['steer_joint']}" if b.get("steer_joint") else ""
            what = f"release at {rel} rad from rest{joint}, {b['settle_s']:.1f} s each"
        print(f"{c['choice']}: {what}: separation {b['separation']:.3g} noise levels ({verdict})")
    if not js["choices"]:
        print(f"{args.diagnosis}: nothing undecided (no alternatives, steer setting recorded, parameters pinned)")
    print(f"wrote {out / 'design.json'} in {time.perf_counter() - t0:.1f} s")
    return 0


@register_command
def _register(sub):
    p = sub.add_parser("design", help="which recording would decide what a diagnosis could not")
    p.add_argument("diagnosis", metavar="DIAGNOSIS_DIR", help="output folder of `roboball diagnose` "
                   "(diagnosis.json, details.json; the recording it names must still be there)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="output folder (design.json, design.md, design.png; default DIAGNOSIS_DIR/design)")
    p.set_defaults(func=cmd_design)
