"""`roboball diagnose RECORDING.csv [MORE.csv ...] --out DIR [--kind KIND] [--pressure-kpa P]
[--steer-joint locked|free|unknown] [--friction-steer FIT.json] [--friction-drive FIT.json]`.

Reads one recording (or one of the authors' native logs), diagnoses it against the baseline
of its kind and writes DIR/diagnosis.json, DIR/report.md (+ figures) and DIR/details.json.
Several recordings of one experiment (same kind and pressure; ramp runs may be on ramps of
different angles, each simulated on its own) are diagnosed together: each of their releases is a
release of the pooled fit, and held-out validation leaves one out (for ramp runs, which hold one
descent each, a whole run).  --friction-steer/--friction-drive
replace the ramp baseline's Table I friction by fitted Majd parameters.
Exit 0 when a diagnosis was made, whatever it found; a one-line error and a non-zero exit on
bad input (wrong columns, unknown kind, empty file: roboball.ingest.recording's validation).
"""
from __future__ import annotations

import time
from pathlib import Path

from roboball.atomic import output_folder
from roboball.cli.main import register_command
from roboball.errors import RoboballError
from roboball.kinds import RECORDED

KINDS = RECORDED
# The steer_coupled baseline's calibrated parts: the pipeline's outputs by default.
COUPLED_REGRESSION = "results/identify/shell_regression.csv"
COUPLED_FRICTION = "results/friction/real/steer_majd.json"


def _kind(text: str) -> str:
    import argparse
    if text not in KINDS:
        raise argparse.ArgumentTypeError(f"unknown kind '{text}' (choose from {', '.join(KINDS)})")
    return text


def _pressure(text: str) -> float:
    import argparse
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--pressure-kpa must be a number, got '{text}'")


class Progress:
    """Progress lines on stderr while a diagnosis runs (tens of seconds on a long log): the
    baseline and each selection round in plain words as they finish, and a line every
    `every_s` seconds of silence (the Drake simulations of the report say nothing).  With
    `verbose`, every message of the search as it comes (BIC differences, held-out errors)."""

    def __init__(self, label: str, verbose: bool = False, every_s: float = 10.0, out=None):
        import sys
        import threading

        self.t0 = self.last = time.perf_counter()
        self.verbose, self.every_s, self.out = verbose, every_s, out or sys.stderr
        # Nothing is said until the recording has been read and checked: a refused recording
        # gets its one-line error alone.
        self.label, self.rounds, self.stage = label, 0, "reading the recording"
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._heartbeat, daemon=True)
        self._thread.start()

    def say(self, text: str) -> None:
        self.last = time.perf_counter()
        print(f"[{self.last - self.t0:5.1f} s] {text}", file=self.out, flush=True)

    def __call__(self, msg: str) -> None:
        """The search's log messages (roboball.diagnose.select), translated."""
        if self.verbose:
            self.say(msg)
        if msg.startswith("data:"):
            self.stage = "fitting the baseline model"
            if not self.verbose:
                self.say(f"diagnosing {self.label} ({msg.split(':', 1)[1].strip()}): {self.stage} ...")
        elif msg.startswith("baseline:"):
            self.stage = "adding candidate effects, one round at a time"
            if not self.verbose:
                fit = msg.split(":", 1)[1].split(", rho1")[0].strip()
                fit = fit.replace("rmse", "RMS error").replace("held-out", "held out")
                self.say(f"baseline fitted ({fit}); {self.stage}")
        elif msg.startswith("round:"):
            self.rounds += 1
            self.stage = f"after round {self.rounds}: testing alternatives, then writing the report"
            if not self.verbose:
                best = msg.split(";", 1)[0].removeprefix("round: best so far ").replace("+", " + ")
                self.say(f"round {self.rounds} done: best model so far {best}")

    def _heartbeat(self) -> None:
        while not self._stop.wait(1.0):
            if time.perf_counter() - self.last >= self.every_s:
                self.say(f"still working ({self.stage})")

    def close(self) -> None:
        self._stop.set()
        self._thread.join()


def _is_coupled(args) -> bool:
    """Whether the recordings are of the coupled steer test (by --kind, else by the first file)."""
    if args.kind is not None:
        return args.kind == "steer_coupled"
    from roboball.ingest.importers import read_any
    return read_any(args.recording[0], pressure_kpa=args.pressure_kpa).kind == "steer_coupled"


def cmd_diagnose_coupled(args) -> int:
    """The coupled steer test: diagnosed in Drake (roboball.diagnose.coupled_report)."""
    from roboball.diagnose.coupled import logged_pressure_of
    from roboball.diagnose.coupled_report import diagnose_coupled, read_inputs

    t0 = time.perf_counter()
    friction = args.friction_steer or COUPLED_FRICTION
    inputs = read_inputs(args.recording, args.regression, friction)
    pressure = logged_pressure_of(args.recording, args.pressure_kpa)     # None: fitted on the data
    label = " + ".join(args.recording)
    progress = Progress(label, verbose=True)
    progress.stage = "Drake runs of the coupled model (pressure, screen, refit, held-out folds)"
    progress.say(f"diagnosing {label}: {progress.stage} ...")
    try:
        js = diagnose_coupled(*inputs, args.out, log=progress, pressure_kpa=pressure)
    except ValueError as exc:
        raise RoboballError(f"{label}: {exc}")
    finally:
        progress.close()
    found = ", ".join(f"{m['effect']} ({m['dof']})" for m in js["missing_physics"]) or "nothing missing"
    pc = js["fit"]["per_coordinate"]
    held = "; ".join(f"{c} {pc['heldout_before'][c]:.4g} -> {pc['heldout_after'][c]:.4g}" for c in pc["before"])
    caveat = " (worse than the baseline held out: not confirmed, see report.md)" if js.get("heldout_warning") else ""
    print(f"{label}: {js['verdict']} ({found}); held out {held} rad{caveat}; "
          f"wrote {Path(args.out) / 'diagnosis.json'} in {time.perf_counter() - t0:.1f} s")
    return 0


def cmd_diagnose(args) -> int:
    from roboball.diagnose import diagnose
    from roboball.diagnose.scored import Settings
    from roboball.identify.friction.fitted import read_diagnosis_friction

    t0 = time.perf_counter()
    for path in args.recording:
        if not Path(path).exists():
            raise RoboballError(f"{path}: file not found")
    coupled = _is_coupled(args)
    if coupled:
        from roboball.diagnose.coupled_report import OUTPUT_FILES
    else:
        from roboball.diagnose.report import OUTPUT_FILES
    output_folder(args.out, create=False, files=OUTPUT_FILES)
    if coupled:
        return cmd_diagnose_coupled(args)
    friction = read_diagnosis_friction(args.friction_steer, args.friction_drive)
    label = " + ".join(args.recording)
    progress = Progress(label, verbose=args.verbose)
    try:
        d, js = diagnose(args.recording, out_dir=args.out, kind=args.kind, pressure_kpa=args.pressure_kpa,
                         settings=Settings(), drake=not args.no_drake, log=progress, friction=friction or None,
                         steer_joint=args.steer_joint)
    except ValueError as exc:     # e.g. a model that cannot represent the recording's kind
        raise RoboballError(f"{label}: {exc}")
    finally:
        progress.close()
    found = ", ".join(m["effect"] for m in js["missing_physics"]) or "nothing missing"
    f = js["fit"]
    print(f"{label}: {js['verdict']} ({found}); rms {f['rmse_before']:.4g} -> {f['rmse_after']:.4g} "
          f"{f['units']}, held out {f['rmse_heldout_before']:.4g} -> {f['rmse_heldout_after']:.4g}; "
          f"wrote {Path(args.out) / 'diagnosis.json'} in {time.perf_counter() - t0:.1f} s")
    return 0


@register_command
def _register(sub):
    p = sub.add_parser("diagnose", help="find the physics a baseline model leaves out of a recording")
    p.add_argument("recording", nargs="+",
                   help="recording CSV (with its JSON sidecar) or an authors' native log; several recordings of "
                        "one experiment (same kind and pressure; ramps of any angle) are diagnosed together")
    p.add_argument("--out", required=True, help="output folder (diagnosis.json, report.md, figures)")
    p.add_argument("--kind", type=_kind, default=None, help="experiment kind (default: the sidecar's)")
    p.add_argument("--pressure-kpa", type=_pressure, default=None, metavar="KPA",
                   help="shell gauge pressure (kPa; default: the sidecar's)")
    p.add_argument("--steer-joint", choices=("locked", "free", "unknown"), default=None,
                   help="shell_rock: whether the pendulum was clamped during the release (default: the sidecar's "
                        "steer_joint, else locked); free fits the steer joint's unobserved release state; unknown "
                        "diagnoses both and reports the one that predicts held-out data better")
    p.add_argument("--friction-steer", default=None, metavar="FIT.json",
                   help="ramp baseline, or shell_rock with --steer-joint free: Majd steer friction from a fit "
                        "(roboball's fit JSON; a free steer joint also takes the fit's rotor inertia delta_i; "
                        "default: Table I); "
                        f"steer_coupled baseline: the stand fit with its delta_i (default: {COUPLED_FRICTION})")
    p.add_argument("--regression", default=COUPLED_REGRESSION, metavar="CSV",
                   help=f"steer_coupled baseline: the shell regression zeta(p), omega_n(p) (default: {COUPLED_REGRESSION})")
    p.add_argument("--friction-drive", default=None, metavar="FIT.json",
                   help="ramp baseline: Majd drive friction from a fit (default: Table I)")
    p.add_argument("--no-drake", action="store_true",
                   help="skip the Drake simulations of the report (default: run them)")
    p.add_argument("--verbose", action="store_true",
                   help="print every step of the search (BIC differences, held-out errors) instead of the "
                        "plain progress lines (default: off)")
    p.set_defaults(func=cmd_diagnose)
