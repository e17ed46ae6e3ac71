"""trellis.distributed: a job sharded over a Dask LocalCluster of two worker processes merges to
the bytes of the single-process run, also when a worker is killed while shards are running."""
import os
import signal
import threading
import time

import pytest

import trellis

import distributed  # noqa: E402,F401  python3-distributed (scripts/install-deps.sh)
from dask.distributed import Client, LocalCluster  # noqa: E402

import trellis.distributed  # noqa: E402

ROOT = os.environ.get("TRELLIS_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
PLATE = os.path.join(ROOT, "examples", "jobs", "gyroid_plate_pbf.toml")


@pytest.fixture(scope="module")
def client():
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as c:
        yield c


def read(path):
    with open(path, "rb") as f:
        return f.read()


def test_dask_shards_merge_to_the_single_run(client, tmp_path):
    single = trellis.run_job(PLATE, output_dir=tmp_path / "single",
                             set={"output.png": "false"}).files[0]
    merged = trellis.distributed.run(PLATE, shards=5, client=client, output_dir=tmp_path / "dask",
                                     set={"output.png": "false"})
    assert merged == str(tmp_path / "dask" / "gyroid_plate.cli")
    assert read(merged) == read(single)
    # Both workers took shards.
    assert len(client.scheduler_info()["workers"]) == 2


def test_gippo_lattice_layers_shard_over_dask_to_the_single_run(client, tmp_path):
    # The plan route: 28 GIPPO layers in travel order (the merge orders each layer from where
    # the layer below ended).
    job = os.path.join(ROOT, "examples", "concave_cylinder_honeycomb.toml")
    sets = {"output.png": "false", "plan.order": "travel"}
    single = [f for f in trellis.run_job(job, output_dir=tmp_path / "single", set=sets).files
              if f.endswith(".gcode")][0]
    merged = trellis.distributed.run(job, shards=3, client=client, output_dir=tmp_path / "dask",
                                     set=sets)
    assert merged == str(tmp_path / "dask" / "concave_cylinder.gcode")
    assert read(merged) == read(single)


def test_a_worker_killed_mid_job_still_gives_the_same_bytes(client, tmp_path):
    # Finer layers: shards long enough (~0.5 s each) to kill a worker while they run.
    sets = {"output.png": "false", "scan.layer": "0.02"}
    single = trellis.run_job(PLATE, output_dir=tmp_path / "single", set=sets).files[0]
    out = tmp_path / "dask"
    result = {}

    def drive():
        try:
            result["path"] = trellis.distributed.run(PLATE, shards=8, client=client,
                                                     output_dir=out, set=sets)
        except BaseException as e:  # reported below
            result["error"] = e

    t = threading.Thread(target=drive)
    t.start()
    killed = None
    deadline = time.time() + 60
    while killed is None and time.time() < deadline and t.is_alive():
        busy = [w for w, tasks in client.processing().items() if tasks]
        done = [f for f in os.listdir(out)] if out.exists() else []
        if busy and any(f.endswith(".json") for f in done):
            pids = client.run(os.getpid, workers=[busy[0]])
            killed = pids[busy[0]]
            os.kill(killed, signal.SIGKILL)
        time.sleep(0.02)
    t.join(120)
    assert killed is not None, "no worker was busy after the first shard: nothing was killed"
    assert "error" not in result, result.get("error")
    assert read(result["path"]) == read(single)
