"""examples/slurm on a real Slurm: munged, slurmctld and slurmd (Debian's munge and slurm-wlm)
started here with their own key, config, ports and state in a temporary folder, one node (this
machine) in one partition. submit.sh submits the shard array and the merge job that depends on it
(afterok); the merged G-code must be the bytes of a one-process `trellis run`, every array task
must have run as its own Slurm job and exited 0, and the merge must have started only after the
last shard ended. Exit 77 (skipped) only when the daemons cannot be started: not root, or the
programs missing.
    slurm_test.py TRELLIS_CLI SOURCE_DIR
"""
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from daemons import Daemons, fail, free_port, require, skip, wait_until  # noqa: E402

SHARDS = 3
JOB_TIMEOUT = 120  # seconds for the array and the merge together (about 10 s unloaded)


def slurm_conf(tmp, node_line, host):
    return f"""ClusterName=trellistest
SlurmctldHost={host}(127.0.0.1)
SlurmctldPort={free_port()}
SlurmdPort={free_port()}
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={tmp}/munge.socket
SlurmUser=root
SlurmdUser=root
StateSaveLocation={tmp}/state
SlurmdSpoolDir={tmp}/spool
SlurmctldPidFile={tmp}/slurmctld.pid
SlurmdPidFile={tmp}/slurmd.pid
SlurmctldLogFile={tmp}/slurmctld.log
SlurmdLogFile={tmp}/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
# Finished jobs stay visible to scontrol for their states and times; a job whose dependency can
# never be met (a shard failed) is cancelled instead of pending forever.
MinJobAge=600
DependencyParameters=kill_invalid_depend
{node_line} NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
"""


def run(argv, env, **kw):
    return subprocess.run(argv, env=env, capture_output=True, text=True, **kw)


def start_munge(daemons, tmp):
    key = os.path.join(tmp, "munge.key")
    with open(os.open(key, os.O_WRONLY | os.O_CREAT, 0o400), "wb") as f:
        f.write(os.urandom(1024))
    sock = os.path.join(tmp, "munge.socket")
    # --force: munged refuses root and a key outside /etc/munge otherwise.
    daemons.start("munged", ["munged", "--foreground", "--force", f"--key-file={key}",
                             f"--socket={sock}", f"--pid-file={tmp}/munged.pid",
                             f"--log-file={tmp}/munged.log", f"--seed-file={tmp}/munged.seed"])

    def credential_round_trip():
        cred = subprocess.run(["munge", "-n", "-S", sock], capture_output=True)
        return cred.returncode == 0 and subprocess.run(
            ["unmunge", "-S", sock], input=cred.stdout, capture_output=True).returncode == 0

    wait_until("munged to answer on its socket", credential_round_trip, 30, daemons)


def job_records(job_id, env):
    """`scontrol -o show job ID`: one dict per job (an array gives one per task)."""
    out = run(["scontrol", "-o", "show", "job", str(job_id)], env)
    if out.returncode != 0:
        fail(f"scontrol show job {job_id}: {out.stderr.strip()}")
    return [dict(re.findall(r"(\w+)=(\S*)", line)) for line in out.stdout.splitlines() if line]


def show_logs(folder):
    for name in sorted(os.listdir(folder)):
        if name.endswith(".log"):
            with open(os.path.join(folder, name), errors="replace") as f:
                print(f"--- {name}\n{f.read()}", file=sys.stderr)


def main():
    if len(sys.argv) != 3:
        fail(__doc__)
    cli, root = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    if os.geteuid() != 0:
        skip("slurmctld, slurmd and munged are started as root here; run as root (CI does)")
    require("munged", "munge", "unmunge", "slurmctld", "slurmd", "sbatch", "squeue", "scontrol",
            "sinfo", hint="apt-get install slurm-wlm munge; scripts/install-deps.sh")
    signal.signal(signal.SIGTERM, lambda *_: sys.exit("terminated"))
    started = time.monotonic()
    tmp = tempfile.mkdtemp(prefix="trellis_slurm_")
    os.chmod(tmp, 0o755)  # munged wants its socket's folder searchable by all
    daemons = Daemons(tmp)
    env = dict(os.environ, SLURM_CONF=os.path.join(tmp, "slurm.conf"))
    for v in [k for k in env if k.startswith(("SLURM_", "SBATCH_", "SQUEUE_")) and k != "SLURM_CONF"]:
        del env[v]
    try:
        for d in ("state", "spool", "submit"):
            os.mkdir(os.path.join(tmp, d))
        start_munge(daemons, tmp)
        # The node as slurmd sees this machine (its name, CPUs, memory).
        hw = run(["slurmd", "-C"], env)
        node_line = hw.stdout.splitlines()[0] if hw.returncode == 0 and hw.stdout else ""
        if not node_line.startswith("NodeName="):
            fail(f"slurmd -C: {hw.stdout}{hw.stderr}")
        host = node_line.split()[0].split("=", 1)[1]
        with open(env["SLURM_CONF"], "w") as f:
            f.write(slurm_conf(tmp, node_line, host))
        daemons.start("slurmctld", ["slurmctld", "-D", "-f", env["SLURM_CONF"]], env)
        daemons.start("slurmd", ["slurmd", "-D", "-f", env["SLURM_CONF"], "-N", host], env)
        wait_until(f"node {host} idle in sinfo",
                   lambda: run(["sinfo", "-h", "-n", host, "-o", "%t"], env).stdout.strip() == "idle",
                   60, daemons)
        up = time.monotonic() - started

        job = os.path.join(root, "examples", "jobs", "lattice_plate_fdm.toml")
        single = run([cli, "run", job, "-o", os.path.join(tmp, "single")], env)
        if single.returncode != 0:
            fail(f"trellis run: {single.stderr}")

        # As a user would: submit.sh from a working folder; the logs land there.
        out = os.path.join(tmp, "plate")
        submitted = time.monotonic()
        sub = run(["bash", os.path.join(root, "examples", "slurm", "submit.sh"), job, out,
                   str(SHARDS), "--cpus-per-task=1", "--mem=1G"],
                  dict(env, TRELLIS=cli), cwd=os.path.join(tmp, "submit"))
        m = re.search(r"job array (\d+) \(1-(\d+)\); merge: job (\d+)", sub.stdout)
        if sub.returncode != 0 or not m:
            fail(f"submit.sh: exit {sub.returncode}\n{sub.stdout}{sub.stderr}")
        array, merge = m.group(1), m.group(3)
        print(f"submitted array {array} (1-{m.group(2)}), merge {merge}", flush=True)

        def queue_empty():
            q = run(["squeue", "-h", "-o", "%i"], env)
            return q.returncode == 0 and q.stdout.strip() == ""

        wait_until("the array and the merge job to leave the queue", queue_empty, JOB_TIMEOUT,
                   daemons, interval=0.5)
        ran = time.monotonic() - submitted

        tasks = [t for t in job_records(array, env) if t.get("ArrayJobId") == array]
        merged = job_records(merge, env)
        states = {t["ArrayTaskId"]: (t["JobState"], t["ExitCode"]) for t in tasks}
        print(f"array tasks: {states}; merge: {merged[0]['JobState']} {merged[0]['ExitCode']}")
        if sorted(states) != [str(k) for k in range(1, SHARDS + 1)] or any(
                s != ("COMPLETED", "0:0") for s in states.values()):
            show_logs(os.path.join(tmp, "submit"))
            fail(f"the array's tasks did not all complete: {states}")
        if (merged[0]["JobState"], merged[0]["ExitCode"]) != ("COMPLETED", "0:0"):
            show_logs(os.path.join(tmp, "submit"))
            fail(f"merge job {merge}: {merged[0]['JobState']} {merged[0]['ExitCode']}")
        if any(t["NodeList"] != host for t in tasks + merged):
            fail("a job did not run on the node")
        # afterok: the merge started when every shard had ended (Slurm's times are whole seconds).
        last_end = max(t["EndTime"] for t in tasks)
        if merged[0]["StartTime"] < last_end:
            fail(f"merge started at {merged[0]['StartTime']}, before the last shard ended ({last_end})")
        logs = sorted(os.listdir(os.path.join(tmp, "submit")))
        want = [f"trellis-merge-{merge}.log"] + [f"trellis-shard-{array}_{k}.log"
                                                 for k in range(1, SHARDS + 1)]
        if logs != want:
            fail(f"job logs {logs}, expected {want}")

        with open(os.path.join(tmp, "single", "lattice_plate.gcode"), "rb") as f:
            one = f.read()
        with open(os.path.join(out, "lattice_plate.gcode"), "rb") as f:
            sharded = f.read()
        if sharded != one:
            fail(f"{out}/lattice_plate.gcode ({len(sharded)} bytes) differs from the one-process "
                 f"run ({len(one)} bytes)")
        print(f"PASSED: {SHARDS} shards + merge on Slurm = the one-process G-code ({len(one)} bytes); "
              f"daemons up in {up:.1f} s, jobs done in {ran:.1f} s, total "
              f"{time.monotonic() - started:.1f} s")
    finally:
        left = run(["squeue", "-h", "-o", "%i"], env).stdout.split() if "slurmctld" in daemons.procs else []
        if left:
            run(["scancel", *left], env)
            deadline = time.monotonic() + 15
            while run(["squeue", "-h", "-o", "%i"], env).stdout.strip() and time.monotonic() < deadline:
                time.sleep(0.5)
        daemons.stop()
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
