"""Warm job starts (roboball.cli.warm): a job forked from the server is the job a fresh
process would run (same bytes, same exit status, same one-line error), a job whose start-up
environment differs runs in a fresh process, a job whose client dies is stopped, the server ends
with the process that started it, and the jobs' CPU time counts to that process."""
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from conftest import REPO
from roboball.cli import warm

pytestmark = pytest.mark.skipif(not hasattr(os, "pidfd_open"), reason="warm starts need Linux's pidfd_open")

RECORDING = REPO / "raw_data" / "shell_rock" / "shell_rock_13.8kpa_r1.csv"
CLIENT = [sys.executable, "-m", "roboball.cli.warm"]


def _ingest_args(out: Path) -> list:
    return ["stage", "ingest", "--src", str(RECORDING), "--out-csv", str(out / "r.csv"),
            "--out-releases", str(out / "r.releases.json"), "--qc-png", str(out / "r.png"),
            "--kind", "shell_rock", "--pressure-kpa", "13.8", "--ramp-angle-deg", ""]


def _log(path: str) -> list:
    return (Path(path).parent / "server.log").read_text().splitlines()


def _wait_ready(path: str, timeout: float = 60.0) -> None:
    """Until the server has preloaded (a first job's answer), so timings below are a job's own."""
    t0 = time.monotonic()
    subprocess.run(CLIENT + ["--help"], env=os.environ, capture_output=True, timeout=timeout)
    assert time.monotonic() - t0 < timeout


@pytest.fixture
def server():
    env_before = dict(os.environ)
    os.environ.update({k: "1" for k in warm.SNAKEMAKE_THREAD_VARS})      # as Snakemake gives a job
    path = warm.start(os.environ)
    assert path and os.environ[warm.ENV_SOCKET] == path
    try:
        yield path
    finally:
        warm.stop(os.environ)
        os.environ.clear()
        os.environ.update(env_before)


def test_the_workflows_jobs_start_warm(tmp_path):
    """Through Snakemake: its jobs' environment (its thread variables, the pinned numerics) is the
    server's, so a job runs warm; its log ends with the job's own CPU time and memory."""
    from test_partial_campaigns import SNAKEMAKE, partial

    raw = partial(tmp_path / "c", drop=("ramp", "steer_coupled", "steer_stand", "drive_stand"), pressures=(13.8,))
    stems = sorted(p.stem for p in raw.glob("shell_rock/*.csv"))[:2]
    work = tmp_path / "w"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k != warm.ENV_SOCKET}
    folders = set(Path(tempfile.gettempdir()).glob("roboball-warm-*"))
    r = subprocess.run([SNAKEMAKE, "-s", str(REPO / "Snakefile"), *[f"results/ingest/{s}.releases.json" for s in stems],
                        "--cores", "2", "--config", f"campaign_dir={raw}", "figures_dir=figures"],
                       cwd=work, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    for stem in stems:
        last = (work / "results" / "logs" / "ingest" / f"{stem}.log").read_text().strip().splitlines()[-1]
        assert last.startswith("roboball: warm start: the job used"), last
    assert set(Path(tempfile.gettempdir()).glob("roboball-warm-*")) <= folders     # the server's folder is gone


def test_a_warm_job_writes_the_bytes_and_status_of_a_fresh_process(server, tmp_path):
    cold, hot = tmp_path / "cold", tmp_path / "warm"
    cold.mkdir(), hot.mkdir()
    r_cold = subprocess.run(CLIENT + _ingest_args(cold), env={**os.environ, warm.ENV_SWITCH: "0"},
                            capture_output=True, text=True)
    r_hot = subprocess.run(CLIENT + _ingest_args(hot), capture_output=True, text=True)
    assert r_cold.returncode == r_hot.returncode == 0, (r_cold.stderr, r_hot.stderr)
    for name in ("r.csv", "r.releases.json", "r.png", "r.pdf"):
        assert (cold / name).read_bytes() == (hot / name).read_bytes(), name
    assert r_hot.stdout == r_cold.stdout
    # the job's own CPU time and memory close its log (Snakemake's benchmark file sees the client)
    assert r_hot.stderr.startswith(r_cold.stderr)
    extra = r_hot.stderr[len(r_cold.stderr):].strip()
    assert extra.startswith("roboball: warm start: the job used") and len(extra.splitlines()) == 1
    cpu = float(extra.split("used ")[1].split(" s of CPU")[0])
    assert 0.05 < cpu < 30.0, extra
    started = [line for line in _log(server) if "roboball stage ingest" in line]
    assert len(started) == 1, _log(server)            # the warm one ran in the server, the cold one did not
    pid = started[0].split()[1].rstrip(":")
    assert f"job {pid}: exit 0" in _log(server)


def test_a_bad_input_fails_warm_as_it_does_cold_in_one_line(server, tmp_path):
    args = ["stage", "ingest", "--src", str(tmp_path / "missing.csv"), "--out-csv", str(tmp_path / "r.csv"),
            "--out-releases", str(tmp_path / "r.json"), "--qc-png", str(tmp_path / "r.png"), "--kind", "shell_rock",
            "--pressure-kpa", "13.8", "--ramp-angle-deg", ""]
    cold = subprocess.run(CLIENT + args, env={**os.environ, warm.ENV_SWITCH: "0"}, capture_output=True, text=True)
    hot = subprocess.run(CLIENT + args, capture_output=True, text=True)
    assert hot.returncode == cold.returncode == 2
    assert hot.stderr == cold.stderr and len(hot.stderr.strip().splitlines()) == 1 and "missing.csv" in hot.stderr
    assert not list(tmp_path.iterdir())
    bad = subprocess.run(CLIENT + ["stage", "no-such-stage"], capture_output=True, text=True)
    assert bad.returncode == 2 and "no-such-stage" in bad.stderr


def test_a_job_with_another_start_up_environment_runs_in_a_fresh_process(server, tmp_path):
    _wait_ready(server)
    before = len(_log(server))
    threads = os.environ.get("NUMBA_NUM_THREADS", "1")
    env = {**os.environ, "NUMBA_NUM_THREADS": "2" if threads == "1" else "1"}
    r = subprocess.run(CLIENT + _ingest_args(tmp_path), env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert len(_log(server)) == before          # the server ran nothing
    assert (tmp_path / "r.csv").exists()


def test_a_job_whose_client_dies_is_interrupted_and_writes_nothing(server, tmp_path):
    _wait_ready(server)
    out = tmp_path / "diagnosis"
    client = subprocess.Popen(CLIENT + ["diagnose", str(RECORDING), "--out", str(out)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    pid = _job_pid(server, "roboball diagnose")
    time.sleep(1.0)
    client.send_signal(signal.SIGTERM)
    client.wait(timeout=10)
    t0 = time.monotonic()
    while f"job {pid}: exit 130" not in _log(server):
        assert time.monotonic() - t0 < warm.KILL_AFTER_S, _log(server)
        time.sleep(0.1)
    assert not out.exists() or not any(out.iterdir())


def test_a_killed_server_takes_its_jobs_with_it(server, tmp_path):
    """As a SIGKILL of Snakemake's process group kills the jobs in it (the kill-and-resume test):
    no orphaned job may write into the rerun's results."""
    _wait_ready(server)
    client = subprocess.Popen(CLIENT + ["diagnose", str(RECORDING), "--out", str(tmp_path / "d")],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    pid = _job_pid(server, "roboball diagnose")
    warm._server[0].kill()
    t0 = time.monotonic()
    while _running(pid):
        assert time.monotonic() - t0 < 5.0, f"job {pid} outlived its server"
        time.sleep(0.05)
    assert client.wait(timeout=10) == 1
    assert "the warm job server stopped during `roboball diagnose" in client.stderr.read()


def _job_pid(server: str, what: str) -> int:
    for _ in range(100):
        lines = [line for line in _log(server) if what in line]
        if lines:
            return int(lines[0].split()[1].rstrip(":"))
        time.sleep(0.1)
    raise AssertionError(f"no job '{what}' started: {_log(server)}")


STARTER = """
import os, sys, resource, subprocess
from roboball.cli import warm
os.environ.update({k: "1" for k in warm.SNAKEMAKE_THREAD_VARS})
warm.start(os.environ)
print(warm._server[0].pid, flush=True)
runs = int(sys.argv[2])
for _ in range(max(runs, 1)):       # --help when no job: a request the server answers after its preload
    args = sys.argv[3:] if runs else ["--help"]
    r = subprocess.run([sys.executable, "-m", "roboball.cli.warm", *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert not runs or "warm start" in r.stderr, r.stderr
if sys.argv[1] == "leave":
    os._exit(0)          # no stop(): the server must notice its starter is gone
warm.stop(os.environ)
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
print(ru.ru_utime + ru.ru_stime)
"""


def _starter(how: str, runs: int, args: list) -> list:
    r = subprocess.run([sys.executable, "-c", STARTER, how, str(runs), *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r.stdout.split()


def test_the_jobs_cpu_time_counts_to_the_process_that_started_the_server(tmp_path):
    """Snakemake's (and `benchmarks/figures_speed.py`'s) CPU time must include the forked jobs':
    the server waits for each job and `stop` waits for the server."""
    idle = float(_starter("stop", 0, [])[1])
    busy = float(_starter("stop", 3, _ingest_args(tmp_path))[1])
    assert busy - idle > 0.6, (idle, busy)     # three ingests, about 0.45 s of a core each


def test_the_server_ends_when_the_process_that_started_it_ends():
    pid = int(_starter("leave", 0, [])[0])
    t0 = time.monotonic()
    while _running(pid):
        assert time.monotonic() - t0 < 5.0, f"the server {pid} outlived its starter"
        time.sleep(0.1)


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/status").read_text().split("State:")[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != "Z"


def test_a_killed_servers_folder_is_removed_by_the_next_start(tmp_path):
    """A SIGKILLed Snakemake (the kill-and-resume test) leaves its server no chance to clean up."""
    stale = Path(tempfile.mkdtemp(prefix=warm.FOLDER_PREFIX))
    (stale / "pid").write_text("999999999")
    (stale / "socket").write_text("")
    young = Path(tempfile.mkdtemp(prefix=warm.FOLDER_PREFIX))      # a server being started: no pid yet
    old = time.time() - 3600
    os.utime(stale, (old, old))
    env = {**os.environ, **{k: "1" for k in warm.SNAKEMAKE_THREAD_VARS}}
    try:
        assert warm.start(env)
        assert not stale.exists() and young.exists()
    finally:
        warm.stop(env)
        shutil.rmtree(young, ignore_errors=True)
        shutil.rmtree(stale, ignore_errors=True)
