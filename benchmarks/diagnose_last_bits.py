"""Do the diagnosis's answers hang on the last bits?  The blind cases diagnosed again with every
recorded angle or rate moved by a part in 10^12 (about a thousand times a double's last bit, a
billion times below the sensor's noise).

    .venv/bin/python benchmarks/diagnose_blind.py --seed 6 --keep DIR      # first: the cases
    .venv/bin/python benchmarks/diagnose_last_bits.py DIR [--real] [--workers 2] [--scale 1e-12] [--json F]

For each case kept in DIR (`DIR/<case>/in/recording.csv` and its sidecar, and the blind run's
`DIR/<case>/out/diagnosis.json`), `roboball diagnose --no-drake` runs twice in a subprocess, under
the pipeline's pinned numerics: on an exact copy of the recording (the control: it must give the
blind run's verdict and effects, or this script measures its own harness), and on the copy with
every signal sample multiplied by 1 + `--scale` (times untouched).  `--real` adds the real steer
stand and the real shell log (`--kind shell_rock --steer-joint unknown`, as the pipeline reads
it) from ../shared beside the checkout.  A physical answer must not move: any case whose verdict
or effect set changes is a decision the keep rule took by rounding; the others are printed with
the largest relative move of a parameter and every parameter moved outside the control's 95%
interval.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pandas as pd

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "roboball_real"      # ../shared beside the checkout
REAL_CASES = (("real steer stand", "steering_static_stand_response.csv", ()),
              ("real shell log", "dynamic_data.csv", ("--kind", "shell_rock", "--steer-joint", "unknown")))


def _diagnose(csv: Path, out: Path, flags=()) -> dict:
    proc = subprocess.run([sys.executable, "-m", "roboball.cli", "diagnose", str(csv), "--out", str(out), "--no-drake",
                           *flags],
                          capture_output=True, text=True, env={**os.environ, "PYTHONHASHSEED": "0"})
    if proc.returncode != 0:
        return {"error": proc.stderr.strip()[-300:]}
    return _answer(json.loads((out / "diagnosis.json").read_text()))


def _answer(js: dict) -> dict:
    mp = js["missing_physics"]
    return {"verdict": js["verdict"], "effects": sorted(m["effect"] for m in mp),
            "parameters": {f"{m['effect']}.{k}": v for m in mp for k, v in m["parameters"].items()},
            "ci95": {f"{m['effect']}.{k}": v for m in mp for k, v in (m.get("ci95") or {}).items()}}


def kept_case(case_dir: Path) -> dict:
    """A case kept by diagnose_blind.py --keep: its recording, sidecar and blind answer."""
    return {"case": case_dir.name, "csv": str(case_dir / "in" / "recording.csv"),
            "sidecar": str(case_dir / "in" / "recording.json"), "flags": (),
            "blind": _answer(json.loads((case_dir / "out" / "diagnosis.json").read_text()))}


def real_case(label: str, name: str, flags) -> dict:
    """A real log (no sidecar, no earlier answer): its flags say what the sidecar would."""
    return {"case": label, "csv": str(REAL / name), "sidecar": None, "flags": tuple(flags), "blind": None}


def run_case(case: dict, scale: float) -> dict:
    """The case diagnosed from an exact copy (`control`) and from its signals times 1 + scale."""
    src = Path(case["csv"])
    with tempfile.TemporaryDirectory(prefix="lastbits_") as tmp:
        tmp = Path(tmp)
        runs = {}
        for name, factor in (("control", None), ("moved", 1.0 + scale)):
            folder = tmp / name
            folder.mkdir()
            if case["sidecar"]:
                shutil.copy(case["sidecar"], folder / src.with_suffix(".json").name)
            if factor is None:
                shutil.copy(src, folder / src.name)
            else:
                df = pd.read_csv(src)
                for c in df.columns:            # every signal; times (and integer time stamps) untouched
                    if "time" not in c and pd.api.types.is_float_dtype(df[c]):
                        df[c] = df[c] * factor
                df.to_csv(folder / src.name, index=False, float_format="%.17g")
            runs[name] = _diagnose(folder / src.name, tmp / f"{name}_out", case["flags"])
    return {"case": case["case"], "blind": case["blind"], **runs}


def _key(answer: dict) -> tuple:
    """What must not move: the verdict and the effect set."""
    return answer.get("verdict"), answer.get("effects")


def _rel_change(a: dict, b: dict) -> float:
    return max((abs(b[k] - v) / abs(v) for k, v in a.items() if k in b and v), default=0.0)


def _outside(control: dict, moved: dict) -> list:
    """The parameters the moved run puts outside the control run's 95% interval, with the move
    in half-widths of that interval."""
    out = []
    for k, v in control.get("parameters", {}).items():
        lo, hi = control.get("ci95", {}).get(k, (v, v))
        w = moved.get("parameters", {}).get(k, v)
        if not lo <= w <= hi:
            half = (hi - lo) / 2 or float("nan")
            out.append(f"{k} {v:.6g} -> {w:.6g} (interval [{lo:.6g}, {hi:.6g}], moved {abs(w - v) / half:.2f} half-widths)")
    return out


def main(argv=None) -> int:
    from roboball.pipeline.numerics import run_pinned
    run_pinned()
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("keep", help="the folder of diagnose_blind.py --keep")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scale", type=float, default=1e-12)
    ap.add_argument("--json", default=None)
    ap.add_argument("--real", action="store_true", help="also the real steer stand and shell log")
    args = ap.parse_args(argv)
    cases = [kept_case(p) for p in sorted(Path(args.keep).iterdir()) if (p / "out" / "diagnosis.json").exists()]
    if not cases:
        raise SystemExit(f"{args.keep}: no case with in/recording.csv and out/diagnosis.json (run diagnose_blind.py --keep)")
    if args.real:
        if not REAL.is_dir():
            raise SystemExit(f"--real: {REAL} is not there (the real logs sit in ../shared beside the checkout)")
        cases += [real_case(*c) for c in REAL_CASES]
    results, moved, harness = [], [], []
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for r in pool.map(run_case, cases, [args.scale] * len(cases)):
            results.append(r)
            if "error" in r["control"] or (r["blind"] is not None and _key(r["control"]) != _key(r["blind"])):
                harness.append(r["case"])
            same = _key(r["moved"]) == _key(r["control"])
            if not same:
                moved.append(r["case"])
            r["change"] = (_rel_change(r["control"].get("parameters", {}), r["moved"].get("parameters", {}))
                           if same else None)
            r["outside"] = _outside(r["control"], r["moved"]) if same else []
            print(f"{r['case']:<16} {r['control'].get('verdict')} {r['control'].get('effects')}"
                  + (f"; moved: same, parameters within {r['change']:.1e}" if same else
                     f"; MOVED: {r['moved'].get('verdict')} {r['moved'].get('effects') or r['moved'].get('error')}")
                  + "".join(f"; OUTSIDE its 95% interval: {o}" for o in r["outside"]), flush=True)
    changes = [r["change"] for r in results if r["change"] is not None]
    print(f"\n{len(results)} cases, signals x (1 + {args.scale:g}): {len(moved)} changed their verdict or effects"
          f"{' (' + ', '.join(moved) + ')' if moved else ''}; the others' parameters moved by at most "
          f"{max(changes, default=0.0):.1e} (relative); outside the control's 95% interval: "
          f"{sum(len(r['outside']) for r in results)} parameters")
    if harness:
        print(f"the control run differs from the blind run in {len(harness)} cases ({', '.join(harness)}): "
              "the comparison is not clean there")
    if args.json:
        Path(args.json).write_text(json.dumps({"scale": args.scale, "cases": results, "moved": moved,
                                               "harness": harness}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
