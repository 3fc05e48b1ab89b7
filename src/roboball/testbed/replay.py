"""The virtual robot runs the experiment of a real log (`roboball-testbed replay`).

    roboball-testbed replay LOG [--pressure-kpa P] --out X.csv

A real log (one of the authors' native formats: `roboball.ingest.importers.NATIVE_FORMATS`)
is an experiment of a known kind whose pressure and release state were not logged.  The
calibrated twin (`load_truth(real=True)`) runs that experiment from the log's own release,
and the recording it writes has the log's columns under the log's names, at the log's own
time stamps (copied from the log), for the rows the experiment covers:

* steer stand (`steer_timestamp`, `pend_angle`): the hand's releases found in the log
  (`roboball.ingest.releases`); each is run on the stand from rest at its release angle to the
  end of its free response (the finder's, before the hand moves the pendulum again);
* shell log (`timestamp`, `ball_roll.position`, `ball_roll.velocity`): the shell release found
  in the log, run with the pendulum free on its steer joint (as the authors' own script models
  this log) from rest, the pendulum hanging plumb, to the end of its free response;
* coupled steer log (`timestamp`, `ball_roll.position`, `roll_joint.position`): trimmed at the
  let-go, run from its first sample with the rates of its first 0.1 s, to its end.

A hand's let-go is not an instant the log records: for the stand's and the shell log's
releases the twin is let go at the finder's instant shifted by the delay (-0.1 to +0.4 s, 5 ms
grid) that fits that free response best, held still before it.  The shell's pressure is the
log's calibrated nuisance value (truth.yaml `real_robot.logs`)
unless `--pressure-kpa` gives one; so is the shell log's pendulum angle at its release (its
offset from plumb; the log does not record the joint) and, where the nuisance values give one,
its rate there (`steer_rate_rad_s`), or instead the joint angle it was held at and how long
before the shell it was let go (`held_joint_rad`, `lead_s`: `pendulum_at_let_go`); the
calibrated twin has neither: its pendulum hangs still.  A bad log is refused with a one-line error naming the file
and what is wrong, and no output is written (the CSV is written atomically).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from roboball.atomic import write_text_atomic
from roboball.errors import RoboballError

# what each native format is as an experiment, and the truth.yaml key of its nuisance values
EXPERIMENT = {"steer_log": "steer_stand", "shell_log": "shell_free", "coupled_log": "steer_coupled"}
NUISANCE_KEY = {"shell_log": "dynamic_data", "coupled_log": "steer_coupled"}
RELEASE_RATE_S = 0.1       # s: the coupled stage's release rates (roboball.diagnose.coupled)
# s: a hand lets go over a fraction of a second, and the release finder places the instant from
# the hold and the swing (roboball.ingest.releases); the let-go the twin is given is the finder's
# instant shifted by the delay in this range that fits that free response best (5 ms grid)
LET_GO_DELAYS_S = np.round(np.arange(-0.10, 0.40 + 1e-9, 0.005), 3)
SIM_RATE_HZ = 500.0        # the twin's output before interpolation to the log's stamps


@dataclass
class RealLog:
    """A real log read for replay: its format, header, raw time cells (text), time (s) and
    the values of every column (rad, rad/s), row by row as in the file."""

    path: Path
    fmt: str
    header: list[str]
    time_cells: list[str]
    t: np.ndarray
    values: dict = field(default_factory=dict)

    @property
    def experiment(self) -> str:
        return EXPERIMENT[self.fmt]

    @property
    def coordinates(self) -> list[str]:
        return self.header[1:]


@dataclass
class Segment:
    """One free response of the experiment: the log's rows it covers and its start."""

    rows: np.ndarray          # indices into the log's rows
    y0: float                 # rad: released angle (the stand's joint, the shell's pipe angle)
    rates0: dict | None = None
    steer0: float | None = None
    let_go_fitted: bool = False   # a hand release: its let-go instant is fitted (LET_GO_DELAYS_S)


def read_log(path) -> RealLog:
    """Read and check a real log; a one-line RoboballError names the file and the fault."""
    from roboball.ingest.csvtable import parse_numeric_csv
    from roboball.ingest.importers import NATIVE_FORMATS, detect_format, read_any

    path = Path(path)
    if not path.is_file():
        raise RoboballError(f"{path}: no such file")
    try:
        fmt = detect_format(path)
    except RoboballError:
        raise
    except Exception as exc:   # an unreadable file: one line naming it
        raise RoboballError(f"{path}: not a readable log ({str(exc).splitlines()[0]})")
    if fmt not in EXPERIMENT:
        known = "; ".join(", ".join(NATIVE_FORMATS[f]["columns"]) for f in EXPERIMENT)
        raise RoboballError(f"{path}: not a real log the twin can replay (format {fmt}); "
                            f"expected the columns of one of: {known}")
    read_any(path)            # the pipeline's own checks: monotone time, units, finite values
    header, values, line_numbers = parse_numeric_csv(path)
    want = list(NATIVE_FORMATS[fmt]["columns"])
    if header != want:
        raise RoboballError(f"{path}: columns {', '.join(header)}; a {NATIVE_FORMATS[fmt]['what']} has exactly "
                            f"{', '.join(want)}")
    lines = path.read_text(encoding="utf-8").splitlines()
    cells = [lines[n - 1].split(",")[0].strip() for n in line_numbers]
    t = values[:, 0] * (1.0 if header[0] == "steer_timestamp" else 1e-9)
    return RealLog(path, fmt, header, cells, t - t[0], {c: values[:, j] for j, c in enumerate(header) if j})


def segments(log: RealLog) -> list[Segment]:
    """The experiment's free responses in the log (see the module docstring)."""
    from roboball.ingest.releases.find import find_releases

    if log.experiment == "steer_coupled":
        m = log.t <= RELEASE_RATE_S
        y, s = log.values["ball_roll.position"], log.values["roll_joint.position"]
        rates = {"pipe_rate": 0.0, "steer_rate": 0.0}
        if m.sum() >= 3:
            rates = {"pipe_rate": float(np.polyfit(log.t[m], y[m], 2)[1]),
                     "steer_rate": float(np.polyfit(log.t[m], s[m], 2)[1])}
        return [Segment(np.arange(len(log.t)), float(y[0]), rates, float(s[0]))]
    coord = log.coordinates[0]
    kind = "steer_stand" if log.experiment == "steer_stand" else "shell_rock"
    releases = find_releases(log.t, log.values[coord], kind)
    if not releases:
        raise RoboballError(f"{log.path}: no release found in {coord} (a hand's hold, then a free response)")
    out = []
    for k, r in enumerate(releases):
        # to the end of its free response (before the hand moves it to the next hold)
        end = min(r.t_end_s, releases[k + 1].held_from_s) if k + 1 < len(releases) else r.t_end_s
        rows = np.nonzero((log.t >= r.t_release_s) & (log.t <= end))[0]
        if len(rows) >= 2:
            out.append(Segment(rows, float(r.y_release), let_go_fitted=True))
    if not out:
        raise RoboballError(f"{log.path}: its releases hold fewer than two samples of free response")
    return out


def pressure_of(log: RealLog, truth: dict, p_kpa: float | None) -> float | None:
    """The shell pressure of the replay: `p_kpa`, else the log's calibrated nuisance value."""
    if log.experiment == "steer_stand":
        if p_kpa is not None:
            raise RoboballError(f"{log.path}: a steer-stand log has no shell pressure (drop --pressure-kpa)")
        return None
    if p_kpa is None:
        return float(truth["logs"][NUISANCE_KEY[log.fmt]]["pressure_kpa"])
    if not (math.isfinite(p_kpa) and 3.0 <= p_kpa <= 40.0):
        raise RoboballError(f"{log.path}: --pressure-kpa {p_kpa:g} is outside 3-40 kPa (the shell's range)")
    return float(p_kpa)


def free_pendulum_run(truth: dict, p_kpa: float, t: np.ndarray, seg: Segment, steer_offset: float = 0.0,
                      steer_rate: float = 0.0) -> dict:
    """The shell released with the pendulum free: both angles and the pipe rate at `t` (s,
    from the release).  `steer_offset` (rad): the log's unknown joint angle at the release,
    from plumb, and `steer_rate` (rad/s) its rate there (nuisance values of the calibration;
    a segment's own state, where it has one, comes first)."""
    import dataclasses

    from roboball.sim.scenarios import simulate
    from roboball.testbed.run import truth_spec

    spec = truth_spec("shell_rock", p_kpa, truth, release=seg.y0)
    spec = dataclasses.replace(spec, kind="steer_coupled")
    # the pendulum hangs plumb while the hand holds the shell (the coupled repeats: pipe -0.36,
    # joint +0.39), unless the segment knows its joint angle
    steer0 = seg.steer0 if seg.steer0 is not None else -seg.y0 + steer_offset
    rates0 = seg.rates0
    if rates0 is None and steer_rate != 0.0:
        rates0 = {"pipe_rate": 0.0, "steer_rate": float(steer_rate)}
    df = simulate(spec, seg.y0, float(t[-1]) + 2 * spec.dt, sample_rate_hz=SIM_RATE_HZ, steer0=steer0,
                  rates0=rates0)
    ts = df["time_s"].to_numpy()
    return {c: np.interp(t, ts, df[c].to_numpy()) for c in ("pipe_angle_rad", "steer_angle_rad", "pipe_rate_rad_s")}


def pendulum_at_let_go(truth: dict, seg: Segment, nuisance: dict) -> tuple[float, float]:
    """The shell log's pendulum at the shell's let-go, from the log's nuisance values: its angle
    (rad, `steer_offset` of `free_pendulum_run`) and rate (rad/s).  Either given as they are
    (`steer_offset_rad`, `steer_rate_rad_s`; absent: hanging still), or as a hold: the joint
    held at `held_joint_rad` with the shell at its release angle and let go at rest `lead_s`
    before the shell, the state the twin's stand run (the pipe held, the truth's joint) reaches
    at that lead (docs/testbed.md, the shell log's let-go)."""
    if "held_joint_rad" not in nuisance:
        return float(nuisance.get("steer_offset_rad", 0.0)), float(nuisance.get("steer_rate_rad_s", 0.0))
    from roboball.testbed.run import run_free

    lead = float(nuisance["lead_s"])
    df, _, _ = run_free("steer_stand", seg.y0 + float(nuisance["held_joint_rad"]), lead + 0.01, truth=truth)
    ts, y = df["time_s"].to_numpy(), df["steer_angle_rad"].to_numpy()
    return float(np.interp(lead, ts, y)), float(np.interp(lead, ts, np.gradient(y, ts)))


def _let_go(t: np.ndarray, ts: np.ndarray, run: dict, main: str, y0: float, measured: np.ndarray) -> dict:
    """The run `run` (columns at its times `ts`, from its let-go) at the log's times `t` (from
    the finder's release instant), let go at the delay of LET_GO_DELAYS_S that fits `measured`
    (the log's `main` column) best: held at y0 (at rest) before it."""
    best, out = np.inf, None
    for delay in LET_GO_DELAYS_S:
        tau = t - delay
        y = np.where(tau < 0.0, y0, np.interp(tau, ts, run[main]))
        sse = float(np.sum((y - measured) ** 2))
        if sse < best:
            best, out = sse, {c: (y if c == main else np.where(tau < 0.0, 0.0 if c.endswith("velocity") else v[0],
                                                                np.interp(tau, ts, v)))
                              for c, v in run.items()}
    return out


def simulate_log(log: RealLog, truth: dict, p_kpa: float | None = None) -> tuple[np.ndarray, dict]:
    """The twin's run of the log's experiment: (the log's rows it covers, {column: values})."""
    from roboball.testbed.run import run_free

    p = pressure_of(log, truth, p_kpa)
    nuisance = truth.get("logs", {}).get(NUISANCE_KEY.get(log.fmt, ""), {})
    main = log.coordinates[0]
    rows, cols = [], {c: [] for c in log.coordinates}
    for seg in segments(log):
        t = log.t[seg.rows] - log.t[seg.rows[0]]
        # a fitted let-go may come up to the largest delay earlier: simulate that much longer
        t_sim = t + (-LET_GO_DELAYS_S[0] if seg.let_go_fitted else 0.0)
        if log.experiment == "steer_stand":
            df, _, _ = run_free("steer_stand", seg.y0, float(t_sim[-1]) + 1e-3, truth=truth)
            ts, run = df["time_s"].to_numpy(), {"pend_angle": df["steer_angle_rad"].to_numpy()}
        else:
            r = free_pendulum_run(truth, p, t_sim, seg, *pendulum_at_let_go(truth, seg, nuisance))
            ts, run = t_sim, {"ball_roll.position": r["pipe_angle_rad"]}
            if "ball_roll.velocity" in cols:
                run["ball_roll.velocity"] = r["pipe_rate_rad_s"]
            if "roll_joint.position" in cols:
                run["roll_joint.position"] = r["steer_angle_rad"]
        if seg.let_go_fitted:
            run = _let_go(t, ts, run, main, seg.y0, log.values[main][seg.rows])
        else:
            run = {c: np.interp(t, ts, v) for c, v in run.items()}
        for c in cols:
            cols[c].append(run[c])
        rows.append(seg.rows)
    return np.concatenate(rows), {c: np.concatenate(v) for c, v in cols.items()}


def rms_by_column(log: RealLog, rows: np.ndarray, pred: dict) -> dict:
    """RMS (rad or rad/s) of the twin against the log, per column, over the replayed rows."""
    return {c: float(np.sqrt(np.mean((pred[c] - log.values[c][rows]) ** 2))) for c in pred}


def replay(path, out, p_kpa: float | None = None, truth: dict | None = None) -> dict:
    """Replay the real log `path` on the calibrated twin and write the recording to `out`
    (atomically: nothing is written if anything fails).  Returns the RMS per column."""
    from roboball.testbed.physics import load_truth

    truth = truth or load_truth(real=True)
    out = Path(out)
    if out.resolve() == Path(path).resolve():
        raise RoboballError(f"{out}: the output would overwrite the log it replays")
    if out.is_dir():
        raise RoboballError(f"{out}: is a folder; --out names the CSV to write")
    log = read_log(path)
    rows, pred = simulate_log(log, truth, p_kpa)
    lines = [",".join(log.header)]
    for k, i in enumerate(rows):
        lines.append(",".join([log.time_cells[i]] + [repr(float(pred[c][k])) for c in log.coordinates]))
    write_text_atomic(out, "\n".join(lines) + "\n")
    return rms_by_column(log, rows, pred)
