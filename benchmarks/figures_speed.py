"""How long `make figures` takes from a fresh clone, and whether the clone's figures are the
committed ones; with `--base`, two commits side by side, so that a speed-up is a ratio measured
in one run on one machine (issue 48, acceptance 1).

    python3 benchmarks/figures_speed.py [--repeats 3] [--keep]
    python3 benchmarks/figures_speed.py --base 407e198 [--head HEAD] [--repeats 2]

Each run clones the repository at a commit next to it (so `../shared/data/roboball_real`, the
real logs, resolves as it does for the checkout), runs `make figures` there (creating `.venv`
first, as a new user's first command does) and records the wall time, the environment's share
of it, the CPU time of every process, the largest resident set of any one process, and the
job-seconds of every rule (from the start and end of each job in Snakemake's log).  Then it
checks the clone's `paper_figures/` against the files committed at that commit.  With `--base`
the two commits alternate (base first in odd repeats, head first in even ones, so that a drift
of the machine's speed falls on both) and the script prints each run, the medians, the ratios
head/base, the rules that gained or lost most, and which `paper_figures/` files of the two
clones differ.  The clones are removed unless `--keep`.  Uses only the standard library: run
it with any Python 3.
"""
from __future__ import annotations

import argparse
import datetime
import filecmp
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TARGET_S = 600.0
# issue 48, acceptance 1: the new code's share of the old's
CPU_TARGET, WALL_TARGET = 0.40, 0.45


def rule_seconds(log: Path) -> dict[str, tuple[int, float]]:
    """rule -> (jobs, seconds from each job's start to its end), from a Snakemake log."""
    stamp = re.compile(r"^\[(\w{3} \w{3} +\d+ [\d:]+ \d{4})\]")
    start, out, now, rule = {}, defaultdict(lambda: [0, 0.0]), None, None
    for line in log.read_text(errors="replace").splitlines():
        m = stamp.match(line)
        if m:
            now = datetime.datetime.strptime(m.group(1), "%a %b %d %H:%M:%S %Y")
            continue
        m = re.match(r"^(?:local)?(?:rule|checkpoint) (\w+):", line)
        if m:
            rule = m.group(1)
            continue
        m = re.match(r"^\s+jobid: (\d+)", line)
        if m and rule:
            start[m.group(1)] = (now, rule)
            rule = None
            continue
        m = re.match(r"^Finished jobid: (\d+)", line)
        if m and m.group(1) in start:
            t0, r = start.pop(m.group(1))
            out[r][0] += 1
            out[r][1] += (now - t0).total_seconds()
    return {r: (n, s) for r, (n, s) in out.items()}


# `make figures` under a process of its own, which reports the largest resident set of the run's
# processes: this script's own RUSAGE_CHILDREN keeps the largest of every run it made before.
_RSS_WRAPPER = """
import resource, subprocess, sys
rc = subprocess.call(sys.argv[2:])
open(sys.argv[1], "w").write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss))
sys.exit(rc)
"""


def run_once(parent: Path, rev: str, keep: bool) -> dict:
    clone = Path(tempfile.mkdtemp(prefix="figures_speed_", dir=parent))
    try:
        subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
        subprocess.run(["git", "checkout", "-q", rev], cwd=clone, check=True)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0, started = time.perf_counter(), time.time()
        rss_file = clone / "make_figures.max_rss_kb"
        with open(clone / "make_figures.log", "w") as log:
            rc = subprocess.run([sys.executable, "-c", _RSS_WRAPPER, str(rss_file), "make", "figures"], cwd=clone,
                                stdout=log, stderr=subprocess.STDOUT).returncode
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        max_rss_kb = int(rss_file.read_text()) if rss_file.exists() else float("nan")
        stamp = clone / ".venv" / ".installed"
        venv = stamp.stat().st_mtime - started if stamp.exists() else float("nan")   # make venv's stamp
        changed = subprocess.run(["git", "status", "--porcelain", "--", "paper_figures"], cwd=clone,
                                 capture_output=True, text=True, check=True).stdout.split("\n")
        changed = sorted(Path(line[3:]).name for line in changed if line.strip())
        logs = sorted((clone / ".snakemake" / "log").glob("*.snakemake.log"), key=lambda p: p.stat().st_size)
        rules = rule_seconds(logs[-1]) if logs else {}
        return dict(rev=rev, rc=rc, wall_s=wall, venv_s=venv, user_s=after.ru_utime - before.ru_utime,
                    sys_s=after.ru_stime - before.ru_stime, max_rss_gb=max_rss_kb / 1024 ** 2,
                    changed=changed, rules=rules, clone=clone)
    except BaseException:
        shutil.rmtree(clone, ignore_errors=True)
        raise


def _min_s(seconds: float) -> str:
    tenths = round(seconds * 10)
    return f"{tenths // 600} min {tenths % 600 / 10:04.1f} s"


def _line(r: dict) -> str:
    return (f"exit {r['rc']}, {_min_s(r['wall_s'])} (.venv {r['venv_s']:.0f} s), "
            f"CPU {r['user_s']:.0f} s user + {r['sys_s']:.0f} s system, peak RSS {r['max_rss_gb']:.2f} GB, "
            f"{sum(n for n, _ in r['rules'].values())} jobs; paper_figures/: "
            + ("as committed" if not r["changed"] else f"DIFFERENT: {', '.join(r['changed'])}"))


def _differing(a: Path, b: Path) -> list[str]:
    """Files of paper_figures/ that differ (or exist in one only) between two clones."""
    out = []
    for root, _, files in os.walk(a / "paper_figures"):
        for f in files:
            pa = Path(root, f)
            pb = b / pa.relative_to(a)
            if not pb.is_file() or not filecmp.cmp(pa, pb, shallow=False):
                out.append(str(pa.relative_to(a / "paper_figures")))
    out += [str(p.relative_to(b / "paper_figures")) for p in (b / "paper_figures").rglob("*")
            if p.is_file() and not (a / p.relative_to(b)).is_file()]
    return sorted(out)


def one_commit(args) -> int:
    head = subprocess.run(["git", "rev-parse", "--short", args.head], cwd=REPO, capture_output=True,
                          text=True, check=True).stdout.strip()
    print(f"make figures from a fresh clone of {head}, {args.repeats} run(s), {os.cpu_count()} cores")
    runs = []
    for i in range(args.repeats):
        r = run_once(REPO.parent, head, args.keep)
        if not args.keep:
            shutil.rmtree(r["clone"], ignore_errors=True)
        runs.append(r)
        print(f"run {i + 1}: " + _line(r), flush=True)
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


def side_by_side(args) -> int:
    revs = {}
    for name, rev in (("base", args.base), ("head", args.head)):
        revs[name] = subprocess.run(["git", "rev-parse", "--short", rev], cwd=REPO, capture_output=True,
                                    text=True, check=True).stdout.strip()
    print(f"make figures from fresh clones, base {revs['base']} against head {revs['head']}, "
          f"{args.repeats} pair(s), {os.cpu_count()} cores", flush=True)
    runs = {"base": [], "head": []}
    for i in range(args.repeats):
        order = ("base", "head") if i % 2 == 0 else ("head", "base")
        pair = {}
        for name in order:
            r = run_once(REPO.parent, revs[name], True)
            pair[name] = r
            runs[name].append(r)
            print(f"pair {i + 1}, {name} {revs[name]}: " + _line(r), flush=True)
        diff = _differing(pair["base"]["clone"], pair["head"]["clone"])
        print(f"pair {i + 1}: paper_figures/ files differing between base and head: "
              + (", ".join(diff) if diff else "none"), flush=True)
        if not args.keep:
            for r in pair.values():
                shutil.rmtree(r["clone"], ignore_errors=True)
    ok = {k: [r for r in v if r["rc"] == 0] for k, v in runs.items()}
    if not ok["base"] or not ok["head"]:
        print("a commit finished no run")
        return 1

    def med(name, key):
        return statistics.median(r[key] for r in ok[name])

    cpu = {k: med(k, "user_s") + med(k, "sys_s") for k in ok}
    wall = {k: med(k, "wall_s") for k in ok}
    print(f"median wall: base {_min_s(wall['base'])}, head {_min_s(wall['head'])}: "
          f"head/base {wall['head'] / wall['base']:.2f} (target {WALL_TARGET:.2f})")
    print(f"median CPU (user + system): base {cpu['base']:.0f} s, head {cpu['head']:.0f} s: "
          f"head/base {cpu['head'] / cpu['base']:.2f} (target {CPU_TARGET:.2f})")
    print(f"median peak RSS: base {med('base', 'max_rss_gb'):.2f} GB, head {med('head', 'max_rss_gb'):.2f} GB")
    rules = sorted(set().union(*(r["rules"] for rs in ok.values() for r in rs)))
    print(f"{'rule':<26}{'base jobs':>10}{'base s':>9}{'head jobs':>10}{'head s':>9}")
    rows = []
    for rule in rules:
        b = [r["rules"].get(rule, (0, 0.0)) for r in ok["base"]]
        h = [r["rules"].get(rule, (0, 0.0)) for r in ok["head"]]
        rows.append((rule, b[0][0], statistics.median(s for _, s in b), h[0][0], statistics.median(s for _, s in h)))
    for rule, bn, bs, hn, hs in sorted(rows, key=lambda x: -max(x[2], x[4])):
        print(f"{rule:<26}{bn:>10}{bs:>9.0f}{hn:>10}{hs:>9.0f}")
    print(f"{'all jobs':<26}{sum(x[1] for x in rows):>10}{sum(x[2] for x in rows):>9.0f}"
          f"{sum(x[3] for x in rows):>10}{sum(x[4] for x in rows):>9.0f}")
    return 0 if all(r["rc"] == 0 for rs in runs.values() for r in rs) else 1


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=None, help="runs (pairs with --base); default 3, 2 with --base")
    ap.add_argument("--base", help="a commit to compare against (side by side)")
    ap.add_argument("--head", default="HEAD", help="the commit measured (default HEAD)")
    ap.add_argument("--keep", action="store_true", help="keep the clones (and their results/)")
    args = ap.parse_args(argv)
    if args.repeats is None:
        args.repeats = 2 if args.base else 3
    if subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=REPO,
                      capture_output=True, text=True).stdout.strip():
        print("note: the checkout has uncommitted changes; the clones run committed code")
    return side_by_side(args) if args.base else one_commit(args)


if __name__ == "__main__":
    sys.exit(main())
