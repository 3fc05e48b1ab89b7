"""A shell release's steer setting (locked, free or unknown) and, when it is unknown, the
diagnosis made both ways (roboball.diagnose.diagnose's `steer_joint`; docs/diagnosis.md, "A shell
release with the pendulum free")."""
from __future__ import annotations

from roboball.diagnose.data import pool, prepare
from roboball.diagnose.scored import Settings
from roboball.diagnose.select import diagnose_prepared
from roboball.errors import RoboballError
from roboball.ingest.sidecar import sidecar_path
from roboball.reduced.shell_steer import ShellSteerModel

STEER_JOINT = ("locked", "free", "unknown")


def either_steer_setting(recs, prep, settings, log, steer_friction: dict | None):
    """A shell release whose steer setting was not recorded, diagnosed with the joint locked and
    with the pendulum free; the free one is reported where its held-out RMS is lower by the keep
    rule's margin (`Settings.cv_gain`: it fits the joint's state besides), else the locked one,
    the contract's default.  The report's notes give both."""
    runs = {}
    for setting in ("locked", "free"):
        if log:
            log(f"data: the steer joint {setting} (its setting is not recorded: both are tried)")
        # each its own prep: a diagnosis writes its notes (and a fitted sensor lag) into it
        p = prep if setting == "locked" else pool([prepare(r) for r in recs])
        model = ShellSteerModel(friction=steer_friction) if setting == "free" else None
        runs[setting] = diagnose_prepared(p, settings=settings, log=log, model=model)
    cv = {k: d.final.cv_rmse for k, d in runs.items()}
    gain = (settings or Settings()).cv_gain
    chosen = "free" if cv["free"] < (1.0 - gain) * cv["locked"] else "locked"
    d = runs[chosen]
    said = "; ".join(f"{k}: {' + '.join(runs[k].chosen) or 'nothing missing'}, held-out RMS {cv[k]:.4g}"
                     for k in ("locked", "free"))
    d.prep.notes.append(f"the steer joint's setting was not recorded (steer_joint unknown): diagnosed with it "
                        f"locked and with the pendulum free ({said}); reported: {chosen}, "
                        + ("its held-out RMS more than " if chosen == "free" else "the free one's held-out RMS not ")
                        + f"{gain:.0%} below the other's")
    # each setting's whole fitted model and intervals, so `roboball design` can simulate both
    d.steer_settings = {k: {"effects": list(runs[k].chosen), "rmse_heldout": cv[k], "values": runs[k].final.values,
                            "ci95": {p: list(v) for p, v in runs[k].ci95.items()}} for k in runs}
    return d


def steer_setting(prep, given: str | None) -> str:
    """The shell release's steer setting: the argument, else the sidecar's `steer_joint`, else
    locked; a one-line error for another value, or for any but locked on a recording that is no
    shell release."""
    rec = prep.recording
    value = given if given is not None else rec.meta.get("steer_joint", "locked")
    if given is not None:
        where = "--steer-joint"
    else:
        where = f"{sidecar_path(rec.path) if rec.path is not None else rec.label}: field steer_joint"
    if value not in STEER_JOINT:
        raise RoboballError(f"{where}: '{value}' is not a steer setting (choose from {', '.join(STEER_JOINT)})")
    if value != "locked" and prep.kind != "shell_rock":
        raise RoboballError(f"{where}: '{value}' applies to shell_rock recordings only, not to {prep.kind}")
    return value
