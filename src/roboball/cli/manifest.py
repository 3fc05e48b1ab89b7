"""`roboball manifest DIR`: write a campaign's MANIFEST.csv for a folder of logs
(roboball.ingest.survey), so that `make figures RAW=DIR` can run on it; with `--out FILE` the
manifest goes there and the folder is left as it is (`make figures RAW=DIR MANIFEST=FILE`)."""
from __future__ import annotations

from pathlib import Path

from roboball.cli.main import register_command
from roboball.ingest.manifest import STEER_JOINTS
from roboball.kinds import RECORDED


def cmd_manifest(args) -> int:
    from roboball.ingest.survey import survey, write_manifest

    rows = survey(args.dir, kind=args.kind, pressure_kpa=args.pressure_kpa, steer_joint=args.steer_joint,
                  ramp_angle_deg=args.ramp_angle_deg, name=args.name)
    path = write_manifest(args.dir, rows, force=args.force, out=args.out)
    width = max(len(r["file"]) for r in rows)
    for r in rows:
        settings = ", ".join(f"{k} {r[k]}" for k in ("pressure_kpa", "steer_joint", "ramp_angle_deg") if r[k])
        print(f"  {r['file']:<{width}}  {r['kind']:<13}  {settings}")
    then = f" MANIFEST={path}" if args.out else ""
    print(f"wrote {path} ({len(rows)} recordings); next: make figures RAW={args.dir}{then}")
    return 0


@register_command
def _register(sub):
    m = sub.add_parser("manifest", help="write DIR/MANIFEST.csv (or --out FILE) for a folder of logs (make figures RAW=DIR)")
    m.add_argument("dir", type=Path, help="the folder of recordings (native logs or time_s CSVs with sidecars)")
    m.add_argument("--kind", choices=RECORDED, help="the kind of logs whose sidecar and format do not tell it")
    m.add_argument("--pressure-kpa", help="shell gauge pressure (kPa) of shell, ramp and coupled logs without one "
                   "in a sidecar, or 'unknown' where it was not logged")
    m.add_argument("--steer-joint", choices=STEER_JOINTS, help="shell releases' steer setting where no sidecar gives it")
    m.add_argument("--ramp-angle-deg", type=float, help="ramp runs' angle where no sidecar gives it (default 16)")
    m.add_argument("--name", default="", help="the campaign's name in figure titles (default: the folder's)")
    m.add_argument("--out", type=Path, help="write the manifest here instead of DIR/MANIFEST.csv, leaving DIR as it "
                   "is (a read-only or archived folder); then make figures RAW=DIR MANIFEST=FILE")
    m.add_argument("--force", action="store_true", help="replace an existing manifest")
    m.set_defaults(func=cmd_manifest)
