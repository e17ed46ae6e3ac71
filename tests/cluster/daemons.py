"""Daemons for the cluster tests: started in the foreground as children of the test (killed with
it if the test itself is killed), waited for with deadlines, always stopped."""
import ctypes
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

SKIP = 77  # CTest's SKIP_RETURN_CODE for the cluster tests (tests/CMakeLists.txt)


def skip(reason):
    print(f"SKIPPED: {reason}", flush=True)
    sys.exit(SKIP)


def fail(message):
    print(f"FAILED: {message}", file=sys.stderr, flush=True)
    sys.exit(1)


def require(*programs, hint):
    missing = [p for p in programs if shutil.which(p) is None]
    if missing:
        skip(f"{', '.join(missing)} not found ({hint})")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _die_with_parent():
    # PR_SET_PDEATHSIG: a daemon outliving a test killed by CTest's timeout would hold its ports
    # and files; this kills it when the test process goes away.
    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)


class Daemons:
    """The processes one test started, by pid; stop() ends each (TERM, then KILL) and is safe to
    call twice. `group=True` puts a process in its own process group so that kill_group() ends it
    with all its children, like a machine going down."""

    def __init__(self, folder):
        self.folder = folder
        self.procs = {}

    def start(self, name, argv, env=None, group=False):
        log = open(os.path.join(self.folder, f"{name}.out"), "wb")
        p = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                             env=env, preexec_fn=_die_with_parent, start_new_session=group)
        log.close()
        p.group = group
        self.procs[name] = p
        return p

    def log(self, name, lines=30):
        path = os.path.join(self.folder, f"{name}.out")
        if not os.path.exists(path):
            return ""
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-lines:])

    def check_alive(self):
        for name, p in self.procs.items():
            if p.poll() is not None and not getattr(p, "killed_on_purpose", False):
                fail(f"{name} exited with {p.returncode}:\n{self.log(name)}")

    def kill_group(self, name):
        p = self.procs[name]
        p.killed_on_purpose = True
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()

    def _signal(self, p, sig):
        try:
            if p.group:
                os.killpg(p.pid, sig)
            elif p.poll() is None:
                p.send_signal(sig)
        except ProcessLookupError:
            pass

    def stop(self):
        procs = list(reversed(self.procs.values()))
        for p in procs:
            self._signal(p, signal.SIGCONT)  # a stopped process would not see the TERM
            self._signal(p, signal.SIGTERM)
        for p in procs:
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                self._signal(p, signal.SIGKILL)
                p.wait()
            if p.group:  # the group's other processes (a nanny's worker) may outlive its leader
                deadline = time.monotonic() + 10
                while _group_alive(p.pid) and time.monotonic() < deadline:
                    time.sleep(0.1)
                self._signal(p, signal.SIGKILL)


def _group_alive(pgid):
    try:
        os.killpg(pgid, 0)
        return True
    except ProcessLookupError:
        return False


def wait_until(what, ready, timeout, daemons=None, interval=0.2):
    """Polls ready() until it returns a true value (returned) or `timeout` seconds pass (fail)."""
    deadline = time.monotonic() + timeout
    while True:
        value = ready()
        if value:
            return value
        if daemons is not None:
            daemons.check_alive()
        if time.monotonic() > deadline:
            fail(f"timed out after {timeout} s waiting for {what}")
        time.sleep(interval)
