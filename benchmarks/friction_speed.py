"""How long each friction fit takes to a converged posterior (issue 7: a Majd posterior under 60 s;
issue 24: every posterior, the real steer log's included, to >= 50 autocorrelation times in
<= 120 s).

    .venv/bin/python benchmarks/friction_speed.py [--repeats 3] [--laws viscous,coulomb_viscous,majd]
                                                  [--logs testbed-steer,testbed-drive,real]

The recordings: the virtual test bed's stands (full test-bed physics: LuGre joint friction, which
no fitted law contains, sensor noise, quantisation, irregular sampling), four hand releases and
about 50 s long, made once with a fixed seed, and the real steer-stand log (../shared beside the
repository, or $ROBOBALL_REAL_DATA; skipped when absent).  Releases are found as the pipeline
finds them (roboball.ingest.releases).  Timed: `roboball.identify.friction.fit.fit` with the
pipeline's settings (configs/config.yaml: walkers, autocorr multiple, step cap; the stand
calibrated, release states marginalised), i.e. least squares, RK4 step choice, emcee to
convergence and the summary, in a fresh chain file each run.  Per fit: the median wall time of
`--repeats` runs and each run's steps, slowest tau, chain/tau and convergence flag.  The drive
stand is fitted with Majd's law only (as the pipeline does).
"""
from __future__ import annotations

import argparse
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def make(folder: Path, joint: str) -> tuple[Path, Path]:
    from roboball.atomic import write_json_atomic
    from roboball.ingest.recording import normalise, read_recording, write_recording
    from roboball.ingest.releases.find import require_releases
    from roboball.testbed.campaign import _rest_angle, release_recording
    from roboball.testbed.physics import load_truth, true_robot
    from roboball.testbed.sensors import measure

    kind = f"{joint}_stand"
    truth = load_truth()
    rng = np.random.default_rng(50)
    rest = _rest_angle(kind, true_robot(truth, perturbed=False))
    dense = release_recording(kind, None, [rest - 1.1, rest + 0.8, rest - 0.9, rest + 1.0], 9.5, truth, rng)
    rec = measure(dense, truth["sensors"], rng)
    path = folder / f"{kind}_bench.csv"
    write_recording(path, rec, {"kind": kind, "pressure_kpa": None})
    rec = normalise(read_recording(path))
    rels = require_releases(rec)
    rel_path = folder / f"{kind}_bench.releases.json"
    write_json_atomic(rel_path, {"kind": kind, "releases": [r.as_dict() for r in rels]})
    return path, rel_path


def real_log(folder: Path) -> tuple[Path, Path] | None:
    """The real steer-stand log ingested as the pipeline does it, or None when it is absent."""
    import os

    from roboball.atomic import write_json_atomic
    from roboball.ingest.importers import read_any
    from roboball.ingest.recording import normalise, write_recording
    from roboball.ingest.releases.find import require_releases

    root = Path(os.environ.get("ROBOBALL_REAL_DATA", Path(__file__).resolve().parents[1].parent / "shared" / "data"
                               / "roboball_real"))
    src = root / "steering_static_stand_response.csv"
    if not src.exists():
        return None
    rec = normalise(read_any(src, kind="steer_stand"))
    path, rel_path = folder / "real_steer_stand.csv", folder / "real_steer_stand.releases.json"
    write_recording(path, rec)
    write_json_atomic(rel_path, {"kind": rec.kind, "releases": [r.as_dict() for r in require_releases(rec)]})
    return path, rel_path


def time_fit(rec: Path, rels: Path, joint: str, law: str, repeats: int, folder: Path, settings: dict) -> list:
    """Run one fit `repeats` times (fresh chains, seeds 0..); returns (wall s, result) per run."""
    from roboball.identify.friction.fit import fit

    runs = []
    for k in range(repeats):
        t0 = time.perf_counter()
        res, _ = fit(rec, rels, joint, law, None, folder / f"{rec.stem}_{law}_{k}.h5", walkers=settings["walkers"],
                     autocorr_multiple=settings["autocorr_multiple"], max_steps=settings["max_steps"], seed=k)
        runs.append((time.perf_counter() - t0, res))
    return runs


def report(name: str, law: str, runs: list) -> str:
    walls = [w for w, _ in runs]
    lines = [f"{name:14s} {law:16s} median {statistics.median(walls):6.1f} s  (runs: "
             f"{', '.join(f'{w:.1f}' for w in walls)})"]
    for w, res in runs:
        c = res["convergence"]
        lines.append(f"{'':31s} converged {str(c['converged']):5s} steps {c['steps']:5d} tau {c['max_tau']:6.1f} "
                     f"chain/tau {c['chain_over_tau']:5.1f}  dt {res['integration']['dt_s']:g} s  "
                     f"rmse {res['fit']['rmse_rad'] * 1e3:.1f} mrad")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--laws", default="viscous,coulomb_viscous,majd")
    ap.add_argument("--logs", default="testbed-steer,testbed-drive,real")
    args = ap.parse_args(argv)
    from roboball.config import CONFIG_DIR, load_yaml

    settings = load_yaml(CONFIG_DIR / "config.yaml")["friction"]
    print(f"machine: {platform.machine()}, python {platform.python_version()}, median of {args.repeats}; "
          f"walkers {settings['walkers']}, autocorr multiple {settings['autocorr_multiple']}, "
          f"max steps {settings['max_steps']}; target: converged in <= 120 s")
    laws = args.laws.split(",")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name in args.logs.split(","):
            joint = "drive" if name == "testbed-drive" else "steer"
            made = real_log(tmp) if name == "real" else make(tmp, joint)
            if made is None:
                print(f"{name}: real steer-stand log not found; skipped")
                continue
            for law in (laws if joint == "steer" else [law for law in laws if law == "majd"]):
                print(report(name, law, time_fit(*made, joint, law, args.repeats, tmp, settings)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
