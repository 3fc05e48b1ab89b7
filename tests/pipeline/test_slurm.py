"""Cluster execution through the SLURM profile.

1. The profile (workflow/profiles/slurm) is valid: a Snakemake dry-run against it lists the jobs
   of a target with the per-rule resources it sets, and it has resources for every rule.
2. A real single-node SLURM on localhost (Debian's slurmctld/slurmd/munge, started here in a
   private temporary directory on free loopback ports, stopped afterwards) runs a small target
   (the ingest of one shell recording) through sbatch, with the profile's resources, and the
   results equal a local run byte for byte.  (One job: the plugin's status polling backs off by
   10 s per check, so every further job costs ~20 s of the test's one-minute budget.)  Skipped with the
   reason when the packages are not installed or the daemons cannot start.

Two details of a one-machine cluster, neither needed on a real one: the private slurm.conf is
not at Debian's default /etc/slurm/slurm.conf, so the client commands get SLURM_CONF; and the
plugin's job step strips every SLURM_* variable before its nested `srun`, so a two-line `srun`
shim on PATH re-exports SLURM_CONF inside the jobs.
"""
from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import yaml

from conftest import REPO as ROOT
SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")
PROFILE = ROOT / "workflow" / "profiles" / "slurm"
STEM = "shell_rock_13.8kpa_r1"
TARGET = f"results/decay/{STEM}.csv"                 # ingest -> decay: two dependent jobs (dry-run)
CLUSTER_TARGET = f"results/ingest/{STEM}.releases.json"   # one job through the real SLURM (time budget)
OUTPUTS = [f"results/ingest/{STEM}.csv", f"results/ingest/{STEM}.json", f"results/ingest/{STEM}.releases.json"]
DAEMONS = ("munged", "slurmctld", "slurmd")
CLIENTS = ("sbatch", "squeue", "sinfo", "srun", "scancel")


def _profile() -> dict:
    return yaml.safe_load((PROFILE / "config.yaml").read_text())


def _workflow_copy(dest: Path) -> Path:
    """The workflow and its inputs in a fresh folder, so runs never touch the repository's results/."""
    dest.mkdir(parents=True)
    shutil.copy2(ROOT / "Snakefile", dest / "Snakefile")
    for sub in ("workflow", "configs", "raw_data"):
        shutil.copytree(ROOT / sub, dest / sub)
    return dest


def _run(cmd, cwd, env=None, timeout=240):
    return subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


# ---- 1. the profile ---------------------------------------------------------------------------------
def test_profile_dry_run_lists_jobs_with_the_profile_resources(tmp_path):
    pytest.importorskip("snakemake_executor_plugin_slurm", reason="snakemake-executor-plugin-slurm not installed")
    wf = _workflow_copy(tmp_path / "wf")
    r = _run([SNAKEMAKE, "-n", "--profile", PROFILE, TARGET], cwd=wf, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    out = r.stdout + r.stderr
    prof = _profile()
    assert prof["executor"] == "slurm"
    for rule in ("ingest", "decay"):
        m = re.search(rf"rule {rule}:.*?resources: ([^\n]*)", out, re.S)
        assert m, f"dry-run lists no {rule} job:\n{out[-3000:]}"
        for key, value in prof["set-resources"][rule].items():
            assert f"{key}={value}" in m.group(1), (rule, key, m.group(1))


def test_profile_sets_resources_for_every_rule():
    rules = set()
    for smk in [ROOT / "Snakefile", *sorted((ROOT / "workflow" / "rules").glob("*.smk"))]:
        rules |= set(re.findall(r"^[ \t]*rule (\w+):", smk.read_text(), re.M))
    rules.discard("all")
    assert {"ingest", "decay", "ramp_sim", "figS1_deflating_ramp"} <= rules, rules
    missing = rules - set(_profile()["set-resources"])
    assert not missing, f"rules without cluster resources in {PROFILE}/config.yaml: {sorted(missing)}"
    for rule, res in _profile()["set-resources"].items():
        assert res["mem_mb"] > 0 and res["runtime"] > 0 and res["cpus_per_task"] >= 1, rule


# ---- 2. a real single-node SLURM ---------------------------------------------------------------------
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _mem_mb() -> int:
    with open("/proc/meminfo") as fh:
        kb = int(next(line for line in fh if line.startswith("MemTotal")).split()[1])
    return min(8000, kb // 1024 - 512)


class LocalSlurm:
    """munged + slurmctld + slurmd for this host, all files in one temporary folder."""

    def __init__(self, d: Path):
        self.d = d
        self.procs: list[subprocess.Popen] = []
        self.host = socket.gethostname()
        self.conf = d / "slurm.conf"
        self.env = dict(os.environ, SLURM_CONF=str(self.conf))
        shim = d / "bin"
        shim.mkdir()
        (shim / "srun").write_text(f'#!/bin/sh\nexport SLURM_CONF={self.conf}\nexec {shutil.which("srun")} "$@"\n')
        (shim / "srun").chmod(0o755)
        self.env["PATH"] = f"{shim}:{Path(sys.executable).parent}:{os.environ.get('PATH', '')}"

    def write_config(self):
        d = self.d
        for sub in ("state", "spool", "munge"):
            (d / sub).mkdir()
        (d / "munge").chmod(0o700)
        key = d / "munge" / "munge.key"
        key.write_bytes(os.urandom(1024))
        key.chmod(0o400)
        self.socket = d / "munge" / "sock"
        ncpu = os.cpu_count() or 1
        self.conf.write_text("\n".join([
            "ClusterName=roboballtest",
            f"SlurmctldHost={self.host}(127.0.0.1)",
            f"SlurmctldPort={_free_port()}", f"SlurmdPort={_free_port()}",
            "AuthType=auth/munge", "CredType=cred/munge", f"AuthInfo=socket={self.socket}",
            "SlurmUser=root", "SlurmdUser=root",
            f"StateSaveLocation={d}/state", f"SlurmdSpoolDir={d}/spool",
            f"SlurmctldPidFile={d}/slurmctld.pid", f"SlurmdPidFile={d}/slurmd.pid",
            f"SlurmctldLogFile={d}/slurmctld.log", f"SlurmdLogFile={d}/slurmd.log",
            "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none", "JobAcctGatherType=jobacct_gather/none",
            "AccountingStorageType=accounting_storage/none", "JobCompType=jobcomp/none",
            "SelectType=select/cons_tres", "SelectTypeParameters=CR_Core_Memory", "SchedulerType=sched/backfill",
            "ReturnToService=2", "MinJobAge=600", "MpiDefault=none", "SwitchType=switch/none", "MailProg=/bin/true",
            f"NodeName={self.host} NodeAddr=127.0.0.1 CPUs={ncpu} RealMemory={_mem_mb()} State=UNKNOWN",
            f"PartitionName=debug Nodes={self.host} Default=YES MaxTime=INFINITE State=UP", ""]))
        # slurmd 22.05 always loads a cgroup plugin, even with task/none and linuxproc.
        (d / "cgroup.conf").write_text("CgroupPlugin=autodetect\nConstrainCores=no\nConstrainRAMSpace=no\n"
                                       "ConstrainDevices=no\n")
        self.key = key

    def _spawn(self, name, cmd):
        log = open(self.d / f"{name}.out", "w")
        self.procs.append(subprocess.Popen(cmd, env=self.env, stdout=log, stderr=subprocess.STDOUT))

    def start(self, timeout=40.0) -> str | None:
        """Start the daemons; None when the node is idle, else why not."""
        self.write_config()
        d = self.d
        self._spawn("munged", ["munged", "-F", "--force", f"--key-file={self.key}", f"--socket={self.socket}",
                               f"--pid-file={d}/munged.pid", f"--log-file={d}/munged.log",
                               f"--seed-file={d}/munge/seed"])
        deadline = time.monotonic() + 10
        while not self.socket.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        self._spawn("slurmctld", ["slurmctld", "-D", "-f", str(self.conf)])
        time.sleep(1.0)
        self._spawn("slurmd", ["slurmd", "-D", "-f", str(self.conf)])
        deadline = time.monotonic() + timeout
        state = ""
        while time.monotonic() < deadline:
            dead = [p.args[0] for p in self.procs if p.poll() is not None]
            if dead:
                return f"{', '.join(dead)} exited: {self.log_tail()}"
            r = subprocess.run(["sinfo", "-h", "-o", "%T"], env=self.env, capture_output=True, text=True)
            state = r.stdout.strip()
            if state == "idle":
                return None
            time.sleep(0.5)
        return f"node not idle after {timeout:g} s (state '{state}'): {self.log_tail()}"

    def log_tail(self) -> str:
        lines = []
        for name in DAEMONS:
            f = self.d / f"{name}.out"
            if f.exists():
                errs = [x for x in f.read_text(errors="replace").splitlines() if "error" in x.lower()]
                lines += [f"{name}: {x}" for x in errs[-2:]]
        return " | ".join(lines) or "no errors logged"

    def stop(self):
        for p in reversed(self.procs):     # only the daemons this object started, by their pid
            if p.poll() is None:
                p.terminate()
        for p in self.procs:
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()

    def jobs(self) -> list[dict]:
        r = subprocess.run(["squeue", "--states=all", "-h", "-o", "%i|%j|%T|%m|%l|%C"], env=self.env,
                           capture_output=True, text=True)
        keys = ("id", "name", "state", "mem", "time", "cpus")
        return [dict(zip(keys, line.split("|"))) for line in r.stdout.splitlines() if line.strip()]


@pytest.fixture(scope="module")
def slurm():
    missing = [x for x in DAEMONS + CLIENTS if shutil.which(x) is None]
    if missing:
        pytest.skip(f"SLURM not installed ({', '.join(missing)} missing): "
                    "apt-get install slurmctld slurmd slurm-client munge")
    if os.geteuid() != 0:
        pytest.skip("a local slurmd must run as root to launch jobs")
    pytest.importorskip("snakemake_executor_plugin_slurm", reason="snakemake-executor-plugin-slurm not installed")
    d = Path(tempfile.mkdtemp(prefix="rbslurm-", dir="/tmp"))   # short: the munge socket path is limited
    cluster = LocalSlurm(d)
    try:
        why = cluster.start()
        if why:
            pytest.skip(f"local SLURM daemons did not start: {why}")
        yield cluster
    finally:
        cluster.stop()
        shutil.rmtree(d, ignore_errors=True)


@pytest.mark.slow
def test_small_target_through_slurm_equals_local_run(slurm, tmp_path):
    """Ingest of one shell recording (validation, release finding, QC plot) as a SLURM job."""
    remote = _workflow_copy(tmp_path / "slurm")
    local = _workflow_copy(tmp_path / "local")
    before = {j["id"] for j in slurm.jobs()}
    cmd = [SNAKEMAKE, "--profile", PROFILE, "--slurm-no-account", "--slurm-status-command", "squeue",
           "--slurm-init-seconds-before-status-checks", "1", "--seconds-between-status-checks", "1",
           "--latency-wait", "5", CLUSTER_TARGET]
    # The cluster run mostly waits for the scheduler: run the local one meanwhile.
    proc = subprocess.Popen([str(c) for c in cmd], cwd=remote, env=slurm.env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    r = _run([SNAKEMAKE, "--cores", "1", CLUSTER_TARGET], cwd=local)
    try:
        out, _ = proc.communicate(timeout=240)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert r.returncode == 0, r.stderr[-3000:]
    assert proc.returncode == 0, (out[-3000:], slurm.log_tail())

    # The job went through sbatch, completed, with the profile's resources for its rule.
    jobs = [j for j in slurm.jobs() if j["id"] not in before]
    assert len(jobs) == 1 and jobs[0]["state"] == "COMPLETED", jobs
    want = _profile()["set-resources"]["ingest"]
    assert jobs[0]["mem"] == f"{want['mem_mb']}M" and jobs[0]["time"] == f"{want['runtime']}:00", jobs[0]
    assert jobs[0]["cpus"] == str(want["cpus_per_task"])
    assert "submitted with SLURM jobid" in out

    # ... and produced exactly what the local run produced.
    for rel in OUTPUTS:
        a, b = (local / rel).read_bytes(), (remote / rel).read_bytes()
        assert a == b, f"{rel} differs between the local and the SLURM run"
        assert len(a) > 100
    assert (remote / f"results/qc/{STEM}.png").stat().st_size > 10_000
