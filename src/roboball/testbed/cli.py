"""`roboball-testbed`: the virtual robot's own command (kept apart from `roboball`, which
must never import the test bed).

    roboball-testbed campaign --out raw_data [--only NAME] [--workers 2]
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
    args = p.parse_args(argv)
    try:
        if args.command == "campaign":
            from roboball.testbed.campaign import generate
            t0 = time.time()
            manifest = generate(args.out, only=args.only, workers=args.workers)
            print(f"wrote {len(manifest)} recordings to {args.out} in {time.time() - t0:.0f} s")
        return 0
    except RoboballError as exc:
        print(f"roboball-testbed: error: {exc}", file=sys.stderr)
        return exc.exit_code


if __name__ == "__main__":
    sys.exit(main())
