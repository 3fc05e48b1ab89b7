"""Warm job starts: one process imports the numeric stack the stages use and forks a job per
`roboball stage` command of the workflow, so a job does not spend its first 0.3-0.8 s of a core
importing NumPy, pandas, SciPy, Matplotlib, Drake and Numba again (measured per stage in
docs/performance.md, "Warm job starts").

Three parts:
- `start` (Snakemake's onstart, local runs only) launches the server with the jobs' own
  environment and puts its socket in ROBOBALL_WARM_SOCKET; `stop` (onsuccess, onerror, exit)
  ends it after its jobs.
- The server imports PRELOAD, then for each request forks the job: the client's descriptors
  become its stdin, stdout and stderr, its folder and environment the client's, and it runs
  `roboball <argv>` as the console script would.  It waits for every job, so each job's CPU time
  counts to Snakemake's like a job it started itself.
- The client, `python -m roboball.cli.warm stage NAME ...` (the rules' ROBOBALL), sends its
  arguments, folder, environment and descriptors, and exits with the job's status.  It runs the
  command in a fresh process instead (`python -m roboball.cli`) when there is no server, and when
  its environment differs from the server's in a variable read at start-up (STARTUP_VARS: the
  pinned numerics, the allocator, Numba's threads, Python's own): a forked job could not honour it.

A client that dies (Snakemake stopping a job) closes its socket; the server then interrupts the
job (SIGINT, as Ctrl-C would; SIGKILL after KILL_AFTER_S).  The server ends when the process that
started it does.  ROBOBALL_WARM=0 runs every job in a fresh process.
"""
from __future__ import annotations

import json
import os
import select
import signal
import socket
import struct
import sys
import time

ENV_SOCKET = "ROBOBALL_WARM_SOCKET"
ENV_SWITCH = "ROBOBALL_WARM"
# What the server imports before it forks: what the stages import from outside the package (not
# scipy.signal: no stage does), the figures' PDF backend and the CLI.
PRELOAD = ("numpy", "pandas", "scipy.optimize", "scipy.stats", "scipy.linalg", "scipy.interpolate",
           "scipy.ndimage", "scipy.special", "matplotlib", "matplotlib.pyplot", "matplotlib.backends.backend_agg",
           "matplotlib.backends.backend_pdf", "pydrake.all", "numba", "emcee", "h5py", "corner", "jinja2",
           "jsonschema", "yaml", "roboball.cli.main")
# Variables read when a process starts or imports PRELOAD: a job that sets one differently runs cold.
STARTUP_VARS = ("NPY_", "OPENBLAS_", "OMP_", "MKL_", "NUMBA_", "GLIBC_TUNABLES", "LD_PRELOAD",
                "LD_LIBRARY_PATH", "MPL", "PYTHON", "LANG", "LC_", "TZ")
# Snakemake sets these to each job's `threads` (snakemake/shell.py); the server starts with the
# value of the workflow's one-thread jobs, so those match it and a rule with more runs cold.
SNAKEMAKE_THREAD_VARS = ("OMP_NUM_THREADS", "GOTO_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                         "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")
KILL_AFTER_S = 10.0
FOLDER_PREFIX = "roboball-warm-"    # in the temporary folder: the socket, the server's log and pid
MODULE = "roboball.cli.warm"        # run as `python -m MODULE`: the server, the rules' client
_HEADER = struct.Struct("!I")
_STATUS = struct.Struct("!iddq")    # exit status, CPU user and system (s), peak resident set (kB)
_server = None      # (Popen, socket folder) of the server this process started


def startup_env(environ) -> dict:
    """The variables of `environ` that a started process has already read (STARTUP_VARS)."""
    return {k: v for k, v in environ.items() if k.startswith(STARTUP_VARS)}


# ---- the workflow's side ----------------------------------------------------------------------
def start(environ=os.environ, threads: int = 1) -> str | None:
    """Launch the server with `environ` (the jobs' environment, with Snakemake's thread variables
    at `threads`), set ENV_SOCKET in it and return the socket's path; None (jobs start cold) with
    ROBOBALL_WARM=0 or off Linux."""
    global _server
    import atexit
    import subprocess
    import tempfile

    if environ.get(ENV_SWITCH, "1").strip() == "0" or not hasattr(os, "pidfd_open") or _server is not None:
        return None
    _remove_stale_folders()
    folder = tempfile.mkdtemp(prefix=FOLDER_PREFIX)
    path = os.path.join(folder, "socket")
    log = open(os.path.join(folder, "server.log"), "wb")  # checkpoint: not a result, the server's live log (a line per job)
    env = {**environ, **{k: str(threads) for k in SNAKEMAKE_THREAD_VARS}}
    proc = subprocess.Popen([sys.executable, "-m", MODULE, "--serve", path, str(os.getpid())],
                            env=env, stdin=subprocess.DEVNULL, stdout=log, stderr=log)
    log.close()
    with open(os.path.join(folder, "pid"), "w") as fh:  # checkpoint: not a result, for _remove_stale_folders
        fh.write(str(proc.pid))
    _server = (proc, folder)
    atexit.register(stop)
    # the socket exists before the preload starts; a job asking during the preload waits for it
    deadline = time.monotonic() + 10.0
    while not os.path.exists(path):
        if proc.poll() is not None or time.monotonic() > deadline:
            stop(environ)
            return None
        time.sleep(0.002)
    environ[ENV_SOCKET] = path
    return path


def _remove_stale_folders() -> None:
    """Remove the folders of servers that were killed (SIGKILL leaves no chance to clean up):
    those whose recorded server no longer runs."""
    import glob
    import shutil
    import tempfile

    for folder in glob.glob(os.path.join(tempfile.gettempdir(), FOLDER_PREFIX + "*")):
        try:
            st = os.stat(folder)
            if st.st_uid != os.getuid() or time.time() - st.st_mtime < 60.0:
                continue        # another user's, or one being started now (its pid not yet written)
            with open(os.path.join(folder, "pid")) as fh:
                pid = int(fh.read())
            with open(f"/proc/{pid}/cmdline", "rb") as fh:
                alive = MODULE.encode() in fh.read()
        except (OSError, ValueError):
            alive = False
        if not alive:
            shutil.rmtree(folder, ignore_errors=True)


def stop(environ=os.environ) -> None:
    """End the server `start` launched (its running jobs interrupted) and wait for it."""
    global _server
    import shutil
    import subprocess

    if _server is None:
        return
    proc, folder = _server
    _server = None
    environ.pop(ENV_SOCKET, None)
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=KILL_AFTER_S + 5.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    shutil.rmtree(folder, ignore_errors=True)


# ---- the client --------------------------------------------------------------------------------
def client(argv: list) -> int:
    """Run `roboball <argv>` in a job forked by the server; cold when there is none (see above)."""
    path = os.environ.get(ENV_SOCKET, "")
    if path and os.environ.get(ENV_SWITCH, "1").strip() != "0":
        try:
            sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            sock.connect(path)
        except OSError:
            sock = None
        if sock is not None:
            try:
                status = _ask(sock, argv)
            except KeyboardInterrupt:       # the job is interrupted too: the server sees this socket close
                return 130
            if status is not None:
                return status
    os.execv(sys.executable, [sys.executable, "-m", "roboball.cli", *argv])


def _ask(sock, argv) -> int | None:
    """The job's exit status, or None when the server will not run it (run it cold)."""
    body = json.dumps({"argv": list(argv), "cwd": os.getcwd(), "env": dict(os.environ)}).encode()
    try:
        socket.send_fds(sock, [_HEADER.pack(len(body)) + body], [0, 1, 2])
        if _recv_exactly(sock, 1) != b"R":
            return None                      # refused (or no server) before anything ran
    except OSError:
        return None
    try:
        status = _recv_exactly(sock, _STATUS.size)
    except OSError:
        status = b""
    if len(status) != _STATUS.size:
        print(f"roboball: the warm job server stopped during `roboball {' '.join(argv[:2])}`", file=sys.stderr)
        return 1
    code, user, system, rss_kb = _STATUS.unpack(status)
    # Snakemake's benchmark file measures this client; a finished job's own figures go to its log
    if code == 0:
        print(f"roboball: warm start: the job used {user + system:.2f} s of CPU ({user:.2f} user, {system:.2f} "
              f"system) and at most {rss_kb / 1024 ** 2:.2f} GB", file=sys.stderr)
    return code


def _recv_exactly(sock, n: int) -> bytes:
    out = b""
    while len(out) < n:
        chunk = sock.recv(n - len(out))
        if not chunk:
            break
        out += chunk
    return out


# ---- the server --------------------------------------------------------------------------------
def serve(path: str, parent: int) -> None:
    """Listen on `path`, preload, then run each request's job; end when `parent` ends or on SIGTERM."""
    import importlib

    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(path)
    listener.listen(64)
    signal.signal(signal.SIGINT, signal.SIG_IGN)     # the terminal's Ctrl-C reaches the jobs through their clients
    stopping = []
    signal.signal(signal.SIGTERM, lambda *_: stopping.append(True))
    wake_r, wake_w = os.pipe()       # a SIGTERM wakes the select below at once
    os.set_blocking(wake_w, False)
    signal.set_wakeup_fd(wake_w)
    for name in PRELOAD:
        if stopping:
            return
        importlib.import_module(name)
    if len(os.listdir("/proc/self/task")) > 1:     # forking a process with threads is not safe: serve no job
        listener.close()
        return
    own = startup_env(os.environ)
    jobs = {}                # pidfd -> [pid, client socket, kill deadline or None]
    by_client = {}           # client socket -> pidfd
    while not stopping and os.getppid() == parent:
        _serve_once(listener, (wake_r, wake_w), own, jobs, by_client)
    listener.close()
    if os.getppid() != parent:       # nobody is left to remove the server's folder
        import shutil
        shutil.rmtree(os.path.dirname(path), ignore_errors=True)
    for job in jobs.values():
        _signal_group(job[0], signal.SIGINT)
    for fd in list(jobs):
        select.select([fd], [], [], KILL_AFTER_S)
        _signal_group(jobs[fd][0], signal.SIGKILL)
        _finish(fd, jobs, by_client)


def _serve_once(listener, pipe: tuple, own: dict, jobs: dict, by_client: dict) -> None:
    """Wait (at most a second, or until a job's kill deadline) and handle what is ready: a new
    request, a job that ended, a client that died, the SIGTERM pipe."""
    timeout = 1.0
    deadlines = [j[2] for j in jobs.values() if j[2] is not None]
    if deadlines:
        timeout = max(0.0, min(timeout, min(deadlines) - time.monotonic()))
    try:
        ready, _, _ = select.select([listener, pipe[0], *jobs, *by_client], [], [], timeout)
    except InterruptedError:
        return
    for r in ready:
        if r is listener:
            _accept(listener, pipe, own, jobs, by_client)
        elif r in jobs:
            _finish(r, jobs, by_client)
        elif r in by_client and not _alive(r):       # the client died: stop its job
            job = jobs[by_client.pop(r)]
            _signal_group(job[0], signal.SIGINT)
            job[2] = time.monotonic() + KILL_AFTER_S
        elif r == pipe[0]:
            os.read(pipe[0], 512)
    for job in jobs.values():
        if job[2] is not None and time.monotonic() >= job[2]:
            _signal_group(job[0], signal.SIGKILL)


def _die_with(server: int) -> None:
    """SIGKILL this process when the server dies (Linux's PR_SET_PDEATHSIG), as a killed process
    group kills the jobs in it; a server that stops normally waits for its jobs first."""
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(1, int(signal.SIGKILL), 0, 0, 0) != 0:       # 1: PR_SET_PDEATHSIG
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_PDEATHSIG) failed")
    if os.getppid() != server:   # the server died before the call
        os._exit(137)


def _alive(conn) -> bool:
    """Whether a client's socket, readable, is still open (a client sends nothing after asking)."""
    try:
        return conn.recv(1) != b""
    except OSError:
        return False


def _signal_group(pid: int, sig) -> None:
    try:
        os.killpg(pid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def _accept(listener, pipe: tuple, own: dict, jobs: dict, by_client: dict) -> None:
    conn, _ = listener.accept()
    fds = []
    try:
        conn.settimeout(10.0)
        msg, fds, _, _ = socket.recv_fds(conn, 1 << 20, 3)
        while len(msg) < _HEADER.size or len(msg) < _HEADER.size + _HEADER.unpack_from(msg)[0]:
            chunk = conn.recv(1 << 20)
            if not chunk:
                raise OSError("request cut short")
            msg += chunk
        request = json.loads(msg[_HEADER.size:])
        if len(fds) != 3 or startup_env(request["env"]) != own:
            conn.sendall(b"N")
            raise OSError("run cold")
        conn.sendall(b"R")
    except (OSError, ValueError, KeyError):
        conn.close()
        for fd in fds:
            os.close(fd)
        return
    server = os.getpid()
    pid = os.fork()
    if pid == 0:
        # the listener, the other clients and their jobs' pidfds are the server's, not the job's
        signal.set_wakeup_fd(-1)
        for f in (listener, conn, *by_client):
            f.close()
        for fd in (*jobs, *pipe):
            os.close(fd)
        _job(request, fds, server)  # never returns
    for fd in fds:
        os.close(fd)
    conn.settimeout(None)
    pidfd = os.pidfd_open(pid)
    print(f"job {pid}: roboball {' '.join(request['argv'][:2])}", flush=True)
    jobs[pidfd] = [pid, conn, None]
    by_client[conn] = pidfd


def _finish(pidfd: int, jobs: dict, by_client: dict) -> None:
    pid, conn, _ = jobs.pop(pidfd)
    by_client.pop(conn, None)
    _, status, usage = os.wait4(pid, 0)
    os.close(pidfd)
    code = os.WEXITSTATUS(status) if os.WIFEXITED(status) else 128 + os.WTERMSIG(status)
    print(f"job {pid}: exit {code}", flush=True)
    try:
        conn.sendall(_STATUS.pack(code, usage.ru_utime, usage.ru_stime, usage.ru_maxrss))
    except OSError:
        pass
    conn.close()


def _job(request: dict, fds: list, server: int) -> None:
    """In the forked child: become the client's process and run its command; exit with its status."""
    import atexit
    import traceback

    code = 1
    try:
        os.setpgid(0, 0)            # its own group: the server can stop it with whatever it started
        _die_with(server)           # a job Snakemake started would die with a killed Snakemake's group
        for sig in (signal.SIGTERM, signal.SIGCHLD):
            signal.signal(sig, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        for fd, target in zip(fds, (0, 1, 2)):
            os.dup2(fd, target)
            os.close(fd)
        sys.stdout.reconfigure(line_buffering=os.isatty(1))
        os.chdir(request["cwd"])
        os.environ.clear()
        os.environ.update(request["env"])
        import tempfile
        tempfile.tempdir = None     # the job's TMPDIR (Snakemake's tmpdir resource), not the server's
        sys.argv = ["roboball", *request["argv"]]
        from roboball.cli.main import main
        try:
            code = main(request["argv"])
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            if exc.code is not None and not isinstance(exc.code, int):
                print(exc.code, file=sys.stderr)
    except KeyboardInterrupt:
        code = 130
    except BaseException:           # as Python reports an uncaught exception
        traceback.print_exc()
        code = 1
    finally:
        try:
            atexit._run_exitfuncs()
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(int(code or 0) & 0xFF)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--serve"]:
        serve(sys.argv[2], int(sys.argv[3]))
    else:
        sys.exit(client(sys.argv[1:]))
