"""How long `make figures` takes from a fresh clone (issue 25, acceptance 5: at most 10 minutes),
and whether the clone's figures are the committed ones.

    python3 benchmarks/figures_speed.py [--repeats 3] [--keep]

Each repeat clones the repository's committed HEAD next to it (so `../shared/data/roboball_real`,
the real logs, resolves as it does for the checkout), runs `make figures` there (creating
`.venv` first, as a new user's first command does) and prints the wall time, the environment's
share of it, the CPU time of every process and the largest resident set.  Then it compares the
clone's `paper_figures/` with the committed files: every file must be identical.  The clones
are removed unless
`--keep`.  Uses only the standard library: run it with any Python 3.
"""
from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TARGET_S = 600.0


def run_once(parent: Path, keep: bool) -> dict:
    clone = Path(tempfile.mkdtemp(prefix="figures_speed_", dir=parent))
    try:
        subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0, started = time.perf_counter(), time.time()
        with open(clone / "make_figures.log", "w") as log:
            rc = subprocess.run(["make", "figures"], cwd=clone, stdout=log, stderr=subprocess.STDOUT).returncode
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        stamp = clone / ".venv" / ".installed"
        venv = stamp.stat().st_mtime - started if stamp.exists() else float("nan")   # make venv's stamp
        changed = subprocess.run(["git", "status", "--porcelain", "--", "paper_figures"], cwd=clone,
                                 capture_output=True, text=True, check=True).stdout.split("\n")
        changed = sorted(Path(line[3:]).name for line in changed if line.strip())
        return dict(rc=rc, wall_s=wall, venv_s=venv, user_s=after.ru_utime - before.ru_utime,
                    sys_s=after.ru_stime - before.ru_stime, max_rss_gb=after.ru_maxrss / 1024 ** 2,
                    changed=changed, clone=str(clone))
    finally:
        if not keep:
            shutil.rmtree(clone, ignore_errors=True)


def _min_s(seconds: float) -> str:
    tenths = round(seconds * 10)
    return f"{tenths // 600} min {tenths % 600 / 10:04.1f} s"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--keep", action="store_true", help="keep the clones (and their results/)")
    args = ap.parse_args(argv)
    if subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=REPO,
                      capture_output=True, text=True).stdout.strip():
        print("note: the checkout has uncommitted changes; the clones run the committed HEAD")
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True,
                          text=True, check=True).stdout.strip()
    print(f"make figures from a fresh clone of {head}, {args.repeats} run(s), {os.cpu_count()} cores")
    runs = []
    for i in range(args.repeats):
        r = run_once(REPO.parent, args.keep)
        runs.append(r)
        extra = sorted(r["changed"])
        print(f"run {i + 1}: exit {r['rc']}, {_min_s(r['wall_s'])} "
              f"(.venv {r['venv_s']:.0f} s), CPU {r['user_s']:.0f} s user + {r['sys_s']:.0f} s system, "
              f"peak RSS {r['max_rss_gb']:.2f} GB; paper_figures/: "
              + ("as committed" if not extra else f"DIFFERENT: {', '.join(extra)}"),
              flush=True)
    ok = [r for r in runs if r["rc"] == 0]
    if not ok:
        print("no run finished")
        return 1
    med = statistics.median(r["wall_s"] for r in ok)
    print(f"median wall time: {_min_s(med)} over {len(ok)} run(s) "
          f"(target {TARGET_S / 60:.0f} min: {'met' if med <= TARGET_S else 'NOT met'})")
    same = all(not r["changed"] for r in ok)
    print(f"paper_figures/ reproduced byte for byte in every run: {'yes' if same else 'NO'}")
    return 0 if len(ok) == len(runs) and same else 1


if __name__ == "__main__":
    sys.exit(main())
