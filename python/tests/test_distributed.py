"""trellis.distributed: a job sharded over a Dask LocalCluster of two worker processes merges to
the bytes of the single-process run. A worker killed mid-run, on a cluster started from the
dask-scheduler and dask-worker commands: tests/cluster/dask_test.py."""
import os

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


def test_a_shard_error_is_raised_as_the_trellis_error_and_nothing_is_merged(client, tmp_path):
    out = tmp_path / "bad"
    with pytest.raises(trellis.SettingError, match="scan.layer"):
        trellis.distributed.run(PLATE, shards=3, client=client, output_dir=out, retries=0,
                                set={"output.png": "false", "scan.layer": "-1"})
    assert not (out / "gyroid_plate.cli").exists()
