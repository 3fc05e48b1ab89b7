"""The free-steer shell model's hidden release state against a recorded one (issue 24).

    .venv/bin/python benchmarks/hidden_steer_state.py

`roboball diagnose --steer-joint free` fits the steer joint's angle and rate at a shell
release, which a shell log does not show.  The authors' three coupled repeats
(`../shared/data/roboball_real/steer_coupled_*.csv`) record both the pipe angle and the steer
joint angle of the same experiment (the pendulum free on its joint): each is diagnosed from its
pipe angle alone, with the pendulum free, and the fitted steer state at the window's start is
compared with the recorded angle there and the recorded rate (a central difference).  Printed
per repeat: the effects found, the held-out RMS, fitted and recorded angle (rad) and rate
(rad/s).  About 2 min.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
REAL = ROOT.parent / "shared" / "data" / "roboball_real"

from roboball.diagnose import diagnose  # noqa: E402
from roboball.ingest.importers import read_any  # noqa: E402
from roboball.ingest.recording import Recording  # noqa: E402


def main() -> int:
    files = sorted(REAL.glob("steer_coupled_*.csv"))
    if not files:
        print(f"no coupled repeats in {REAL}")
        return 1
    print("repeat | effects | held-out RMS (rad) | steer angle fitted / recorded (rad) | steer rate fitted / recorded (rad/s) | s")
    for f in files:
        rec = read_any(f, kind="steer_coupled")
        t, steer = rec.time, rec.signal("steer_angle_rad")
        pipe_only = Recording(pd.DataFrame({"time_s": t, "pipe_angle_rad": rec.signal("pipe_angle_rad")}),
                              {"kind": "shell_rock", "pressure_kpa": None, "pressure_source": "unknown", "name": f.stem})
        t0 = time.perf_counter()
        d, js = diagnose(pipe_only, steer_joint="free")
        w = d.prep.windows[0]
        v = d.final.values
        at = w.t0 + v.get(f"ts@{w.index}", 0.0)
        angle = float(np.interp(at, t, steer))
        rate = float(np.interp(at, t, np.gradient(steer, t)))
        effects = " + ".join(m["effect"] for m in js["missing_physics"]) or "nothing"
        print(f"{f.stem} | {effects} | {js['fit']['rmse_heldout_after']:.4f} | "
              f"{v[f'steer_angle@{w.index}']:+.3f} / {angle:+.3f} | {v[f'steer_rate@{w.index}']:+.2f} / {rate:+.2f} | "
              f"{time.perf_counter() - t0:.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
