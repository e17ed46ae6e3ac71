"""trellis.distributed on a Dask cluster started as a user starts one: `dask-scheduler` and two
`dask-worker` commands (Debian's python3-distributed), each its own process tree, joined through a
scheduler file. While the shards run, one worker's whole process tree is killed (SIGKILL, its
nanny too, so nothing replaces it) at a moment it has handed over one shard and is computing
another; the run must still merge to the bytes of the one-process run, with that shard
recomputed on the surviving worker and the shards the killed worker had finished not computed
again. Exit 77 (skipped) only when the programs are missing.
    dask_test.py PYTHON_PACKAGE_DIR SOURCE_DIR
"""
import os
import shutil
import signal
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from daemons import Daemons, fail, require, wait_until  # noqa: E402

SHARDS = 8
# Finer layers than the example's: shards of about a second each (more under load), long enough
# for the test to see one running and stop its worker in the middle.
SETS = {"output.png": "false", "scan.layer": "0.005"}
RUN_TIMEOUT = 120


def worker_now(dask_worker):
    """On a worker (client.run): the keys it is computing, how many tasks it has finished, and how
    many results it still holds."""
    state = dask_worker.state
    return sorted(str(ts.key) for ts in state.executing), state.executed_count, len(dask_worker.data)


def task_place(key, dask_scheduler=None):
    """On the scheduler: the task's state and the worker computing it, if any."""
    ts = dask_scheduler.tasks.get(key)
    if ts is None:
        return None, None
    return ts.state, ts.processing_on.address if ts.processing_on else None


def catch_a_worker_computing(client, daemons, names, out, running):
    """Waits for a worker that has finished a shard, whose result the client has taken (the
    worker holds none), and that is computing another; stops that worker's processes (SIGSTOP)
    and makes sure from the scheduler that the shard is still in its hands, so that the SIGKILL
    lands mid-shard with no race against the shard's end. Returns (worker address, its shard's
    key, shard manifests written at the kill)."""
    def manifests():
        return [f for f in os.listdir(out) if ".shard-" in f and f.endswith(".json")] \
            if os.path.isdir(out) else []

    while running():
        for addr, (keys, executed, held) in client.run(worker_now).items():
            if not keys or executed < 1 or held:
                continue
            proc = daemons.procs[names[addr]]
            os.killpg(proc.pid, signal.SIGSTOP)
            time.sleep(0.5)  # a result already on the wire reaches the scheduler meanwhile
            state, where = client.run_on_scheduler(task_place, keys[0])
            if state == "processing" and where == addr:
                written = len(manifests())
                daemons.kill_group(names[addr])
                return addr, keys[0], written
            os.killpg(proc.pid, signal.SIGCONT)  # it finished first: look again
        time.sleep(0.05)
    fail(f"the run ended (or {RUN_TIMEOUT} s passed) and no worker was seen computing a shard "
         "after handing over the result of its first (trellis.distributed.run must take each "
         "result as its shard ends)")


def main():
    if len(sys.argv) != 3:
        fail(__doc__)
    package, root = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    require("dask-scheduler", "dask-worker",
            hint="apt-get install python3-distributed; scripts/install-deps.sh")
    sys.path.insert(0, package)
    import trellis
    import trellis.distributed
    from dask.distributed import Client, get_task_stream

    signal.signal(signal.SIGTERM, lambda *_: sys.exit("terminated"))
    started = time.monotonic()
    tmp = tempfile.mkdtemp(prefix="trellis_dask_")
    daemons = Daemons(tmp)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [package] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    client = None
    try:
        plate = os.path.join(root, "examples", "jobs", "gyroid_plate_pbf.toml")
        t0 = time.monotonic()
        single = trellis.run_job(plate, output_dir=os.path.join(tmp, "single"), set=SETS).files[0]
        one_process = time.monotonic() - t0

        sched_file = os.path.join(tmp, "scheduler.json")
        t0 = time.monotonic()
        daemons.start("scheduler", ["dask-scheduler", "--host", "127.0.0.1", "--port", "0",
                                    "--no-dashboard", "--scheduler-file", sched_file], env)
        wait_until("the scheduler file", lambda: os.path.exists(sched_file), 60, daemons)
        for name in ("worker-a", "worker-b"):
            os.mkdir(os.path.join(tmp, name))
            daemons.start(name, ["dask-worker", "--scheduler-file", sched_file, "--name", name,
                                 "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                                 "--host", "127.0.0.1",
                                 "--local-directory", os.path.join(tmp, name)],
                          env, group=True)
        client = Client(scheduler_file=sched_file, timeout=60)
        wait_until("two workers", lambda: len(client.scheduler_info()["workers"]) == 2, 60,
                   daemons)
        names = {a: w["name"] for a, w in client.scheduler_info()["workers"].items()}
        up = time.monotonic() - t0

        out = os.path.join(tmp, "dask")
        result = {}

        def drive():
            try:
                result["path"] = trellis.distributed.run(plate, shards=SHARDS, client=client,
                                                         output_dir=out, set=SETS)
            except BaseException as e:  # reported below
                result["error"] = e

        t0 = time.monotonic()
        with get_task_stream(client=client) as stream:
            t = threading.Thread(target=drive, daemon=True)
            t.start()
            victim, key, written = catch_a_worker_computing(
                client, daemons, names, out,
                lambda: t.is_alive() and time.monotonic() - t0 < RUN_TIMEOUT)
            killed_at = time.monotonic() - t0
            t.join(RUN_TIMEOUT)
            if t.is_alive():
                fail(f"the sharded run did not finish in {RUN_TIMEOUT} s after the kill")
        sharded = time.monotonic() - t0
        print(f"killed {names[victim]} ({victim}) {killed_at:.1f} s into the run while it computed "
              f"{key}; {written} of {SHARDS} shards were written then", flush=True)
        if "error" in result:
            fail(f"trellis.distributed.run raised {result['error']!r}")

        survivor = [a for a in names if a != victim][0]
        runs = [(r["key"], r["worker"]) for r in stream.data
                if r["key"].startswith("run_shard-") and r.get("status") == "OK"]
        finished = {}
        for k, w in runs:
            finished.setdefault(k, []).append(w)
        if len(finished) != SHARDS:
            fail(f"{len(finished)} shards finished, not {SHARDS}: {finished}")
        if finished.get(key) != [survivor]:
            fail(f"the killed worker's shard {key} finished on {finished.get(key)}, not on the "
                 f"surviving worker {survivor} alone")
        # The shards the killed worker had finished were not lost with it.
        twice = {k: [names[w] for w in ws] for k, ws in finished.items() if len(ws) > 1}
        if twice:
            fail(f"shards computed twice: {twice}")
        left = list(client.scheduler_info()["workers"])
        if left != [survivor]:
            fail(f"workers at the end: {left}; expected only the survivor {survivor}")
        with open(single, "rb") as f:
            one = f.read()
        with open(result["path"], "rb") as f:
            merged = f.read()
        if merged != one:
            fail(f"{result['path']} ({len(merged)} bytes) differs from the one-process run "
                 f"({len(one)} bytes)")
        per_worker = {names[a]: [w for _, w in runs].count(a) for a in names}
        print(f"PASSED: {SHARDS} shards merged to the one-process bytes ({len(one)} bytes), each "
              f"finished once; shards finished per worker {per_worker}; one "
              f"process {one_process:.1f} s, cluster up in "
              f"{up:.1f} s, sharded run {sharded:.1f} s, total {time.monotonic() - started:.1f} s")
    finally:
        if client is not None:
            client.close()
        daemons.stop()
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
