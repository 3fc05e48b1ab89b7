"""A shell release's steer setting (locked, free or unknown) and, when it is unknown, the
diagnosis made both ways (roboball.diagnose.diagnose's `steer_joint`; docs/diagnosis.md, "A shell
release with the pendulum free")."""
from __future__ import annotations

import math
import threading

from roboball.diagnose.beside import Beside, second_thread
from roboball.diagnose.crossval import paired_heldout
from roboball.diagnose.data import pool, prepare
from roboball.diagnose.scored import Settings
from roboball.diagnose.select import diagnose_prepared
from roboball.errors import RoboballError
from roboball.ingest.sidecar import sidecar_path
from roboball.reduced.shell_steer import ShellSteerModel

STEER_JOINT = ("locked", "free", "unknown")


def either_steer_setting(recs, prep, settings, log, steer_friction: dict | None):
    """A shell release whose steer setting was not recorded, diagnosed with the joint locked and
    with the pendulum free.  A setting is decided when its held-out RMS is lower than the other's
    by the keep rule's margin (`Settings.cv_gain`: the free one fits the joint's state besides),
    the gain is significant (`Settings.decide_p`, crossval.paired_heldout: a short or small
    release holds few independent samples, and there two unreliable fits can differ by more than
    the margin by chance), and it explains the recording: its diagnosis is not `unexplained`, or
    its held-out RMS is at most `Settings.explained_ratio` (a tenth) of the other's, the verdict's
    own test with the other setting in the baseline's place (between two misfits of a similar
    size the free pendulum's fitted release state absorbs what the locked model shows; a tenth
    of the other's RMS is 99% of its held-out square removed, which no absorbed misfit does).
    The decided setting is reported; an undecided one reports the contract's default, locked, and
    says that the recording cannot tell (`roboball design` names the recording that would).  The
    report's notes give both."""
    # made here, before any thread: a shell model's rolling radius is a Drake run (cached), and
    # the searches themselves run no Drake
    models = {"locked": None, "free": ShellSteerModel(friction=steer_friction)}

    def one(setting, say):
        if say:
            say(f"data: the steer joint {setting} (its setting is not recorded: both are tried)")
        # each its own prep: a diagnosis writes its notes (and a fitted sensor lag) into it
        p = prep if setting == "locked" else pool([prepare(r) for r in recs])
        return diagnose_prepared(p, settings=settings, log=say, model=models[setting])

    runs = both_settings(one, log)
    s = settings or Settings()
    cv = {k: d.final.cv_rmse for k, d in runs.items()}
    # ms_ratio > 1: the free model's held-out errors are the smaller
    test = paired_heldout(runs["free"].final, runs["free"].prep.windows, runs["locked"].final, runs["locked"].prep.windows)
    better, decided, verdict = decide(cv, {k: d.verdict for k, d in runs.items()}, test, s)
    chosen = better if decided else "locked"
    d = runs[chosen]
    said = "; ".join(f"{k}: {' + '.join(runs[k].chosen) or 'nothing missing'}, held-out RMS {cv[k]:.4g}"
                     for k in ("locked", "free"))
    d.prep.notes.append(f"the steer joint's setting was not recorded (steer_joint unknown): diagnosed with it "
                        f"locked and with the pendulum free ({said}); {verdict}")
    # each setting's whole fitted model and intervals, so `roboball design` can simulate both
    d.steer_settings = {k: {"effects": list(runs[k].chosen), "rmse_heldout": cv[k], "values": runs[k].final.values,
                            "ci95": {p: list(v) for p, v in runs[k].ci95.items()}} for k in runs}
    d.steer_decision = {"reported": chosen, "decided": decided, "lower_heldout": better,
                        "test": {k: (float(f"{v:.6g}") if isinstance(v, float) and math.isfinite(v) else v)
                                 for k, v in test.items()}}
    return d


def both_settings(one, log) -> dict:
    """{"locked": one("locked", log), "free": one("free", ...)}: given a second thread (Numba's
    count; the workflow gives each job one) the two diagnoses run side by side, the free one in a
    daemon thread (roboball.diagnose.beside), with the same results as one
    after the other: the two share nothing they write.  The messages come in a sequential run's
    order: the free one's are held while the locked one runs, then said and passed on as they
    come (the free search is the longer)."""
    if not second_thread():
        return {"locked": one("locked", log), "free": one("free", log)}
    gate = _Gate(log) if log else None
    free = Beside(one, "free", gate)
    locked = one("locked", log)         # in this thread, where Ctrl-C lands
    if gate:
        gate.open()
    return {"locked": locked, "free": free.result()}


class _Gate:
    """A log that holds its messages until opened, then says them in order and passes the rest
    on as they come."""

    def __init__(self, log):
        self.log, self.held, self.is_open, self.lock = log, [], False, threading.Lock()

    def __call__(self, message: str) -> None:
        with self.lock:
            if self.is_open:
                self.log(message)
            else:
                self.held.append(message)

    def open(self) -> None:
        with self.lock:
            for message in self.held:
                self.log(message)
            self.held, self.is_open = [], True


def decide(cv: dict, verdicts: dict, test: dict, s: Settings) -> tuple:
    """The steer setting's decision (either_steer_setting's rule).

    Args:
        cv: setting ("locked", "free") -> its diagnosis's held-out RMS.
        verdicts: setting -> its diagnosis's verdict.
        test: crossval.paired_heldout of the free against the locked diagnosis.
        s: the settings (`cv_gain`, `decide_p`, `explained_ratio`).

    Returns:
        (the setting of lower held-out RMS by the margin or None, whether it is decided, the
        sentence the report's notes give).
    """
    better = "free" if cv["free"] < (1.0 - s.cv_gain) * cv["locked"] else (
        "locked" if cv["locked"] < (1.0 - s.cv_gain) * cv["free"] else None)
    significant = test["p_two_sided"] < s.decide_p and (test["ms_ratio"] > 1.0) == (better == "free")
    # two settings that both leave the recording unexplained are compared on their misfits, and
    # the free one's fitted joint state can absorb a misfit the locked one shows, unless it
    # removes nearly all of the other's (the test bed's coupled pendulum leaves the reduced free
    # model 4 noise levels: 1.7 mrad held out against the locked model's 20 mrad)
    explains = better is not None and (verdicts[better] != "unexplained"
                                       or cv[better] <= s.explained_ratio * cv[_other(better)])
    decided = better is not None and significant and explains
    p_said = f"p = {test['p_two_sided']:.2g} over {test['n_eff']:.3g} effectively independent samples"
    if decided:
        return better, True, (f"reported: {better}, decided (held-out RMS {cv[better]:.4g} against "
                              f"{cv[_other(better)]:.4g}, more than {s.cv_gain:.0%} below, {p_said})")
    if better is None:
        why = f"the two held-out RMS are within {s.cv_gain:.0%} of each other"
    else:
        lower = f"{better}'s held-out RMS is lower ({cv[better]:.4g} against {cv[_other(better)]:.4g}"
        why = (f"{lower}, p = {test['p_two_sided']:.2g}) but its diagnosis leaves the recording unexplained "
               f"and its held-out RMS is above {s.explained_ratio:g} of the other's"
               if significant else f"{lower}) but not significantly ({p_said}; {s.decide_p:g} needed)")
    return better, False, f"reported: locked, the contract's default: UNDECIDED, {why}"


def _other(setting: str) -> str:
    return "free" if setting == "locked" else "locked"


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
