"""`roboball-testbed`: the virtual robot's own command (kept apart from `roboball`, which
must never import the test bed).

    roboball-testbed campaign --out raw_data [--only NAME] [--workers 2]
    roboball-testbed replay LOG [--pressure-kpa P] --out X.csv
"""
from __future__ import annotations

import argparse
import sys
import time

from roboball.errors import RoboballError


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="roboball-testbed", description="virtual test bed of the robot")
    sub = p.add_subparsers(dest="command", required=True)
    c = sub.add_parser("campaign", help="regenerate the experimental campaign (raw_data/) from the seed")
    c.add_argument("--out", default="raw_data")
    c.add_argument("--only", default=None, help="only files whose name contains this text (no MANIFEST)")
    c.add_argument("--workers", type=int, default=2)
    r = sub.add_parser("replay", help="the calibrated twin runs the experiment of a real log (same columns)")
    r.add_argument("log", help="a real log (steer stand, shell or coupled steer log)")
    r.add_argument("--pressure-kpa", type=float, default=None,
                   help="shell pressure (kPa); default: the log's calibrated value (truth.yaml real_robot.logs)")
    r.add_argument("--out", required=True, help="the CSV to write")
    args = p.parse_args(argv)
    try:
        if args.command == "campaign":
            from roboball.testbed.campaign import generate
            t0 = time.time()
            manifest = generate(args.out, only=args.only, workers=args.workers)
            print(f"wrote {len(manifest)} recordings to {args.out} in {time.time() - t0:.0f} s")
        elif args.command == "replay":
            from roboball.testbed.replay import replay
            t0 = time.time()
            err = replay(args.log, args.out, args.pressure_kpa)
            print(f"wrote {args.out} in {time.time() - t0:.0f} s; RMS against the log: "
                  + ", ".join(f"{c} {v:.4f}" for c, v in err.items()))
        return 0
    except RoboballError as exc:
        print(f"roboball-testbed: error: {exc}", file=sys.stderr)
        return exc.exit_code


if __name__ == "__main__":
    sys.exit(main())
