"""Exact sharding of a Trellis job over a Dask cluster (``trellis run --shard`` + ``trellis merge``).

A job of the ``pbf`` or ``slice`` route (one part or a build plate of ``[[part]]`` tables), of the
``nonplanar`` route or of the ``plan`` route with the ``euler`` or ``gippo`` planner is cut
into ``shards`` layer ranges balanced by estimated work; each range runs as one Dask task on any
worker, writing its shard file and manifest into ``output_dir``; the client then merges them into
exactly the bytes ``trellis run`` writes in one process::

    from dask.distributed import Client, LocalCluster
    import trellis.distributed

    with LocalCluster(n_workers=4, processes=True) as cluster, Client(cluster) as client:
        out = trellis.distributed.run("examples/jobs/gyroid_plate_pbf.toml", client=client,
                                      shards=8, output_dir="out/plate")

On a cluster, pass ``scheduler="tcp://host:8786"`` or a ``Client`` (e.g.
``Client(scheduler_file=...)`` for workers started with ``dask-worker --scheduler-file``) instead;
``output_dir`` must then be a folder every worker and the client see (a shared file system), and
the workers must import ``trellis``. A worker that dies mid-job loses the shard it was computing:
Dask gives it to another worker, which computes it again (``retries`` more times for shards that
raise), and the merged file is the same bytes (tests/cluster/dask_test.py kills one).
"""
import os

from . import _trellis

__all__ = ["run", "run_shard"]


def run_shard(job, output_dir, shard, shards, set=None):
    """Runs shard ``shard`` of ``shards`` (1-based) of the job file; returns its manifest's path."""
    sets = [f"{k}={v}" for k, v in (set or {}).items()]
    files = _trellis.run_shard(os.path.abspath(os.fspath(job)),
                               os.path.abspath(os.fspath(output_dir)) if output_dir else "",
                               sets, f"{shard}/{shards}")
    return files[-1]


def run(job, shards, client=None, scheduler=None, output_dir=None, output=None, set=None,
        retries=2):
    """Runs the job in ``shards`` Dask tasks and merges them; returns the merged file's path.

    ``client``: a ``distributed.Client``; else one is made for ``scheduler`` (an address), and
    without either a ``LocalCluster`` of this machine's cores is started for the call.
    ``output``: the merged file (default: the job's own output, named as ``trellis run`` names
    it in ``output_dir``). Errors of a shard (a bad setting, a plate that does not fit) are
    raised here as ``trellis`` errors; nothing is merged then.
    """
    from dask.distributed import Client, LocalCluster, as_completed  # python3-distributed

    if not isinstance(shards, int) or shards < 1:
        raise ValueError("shards must be a positive integer")
    own = []
    try:
        if client is None:
            if scheduler is not None:
                client = Client(scheduler)
                own.append(client)
            else:
                cluster = LocalCluster(processes=True)
                own.append(cluster)
                client = Client(cluster)
                own.append(client)
        job = os.path.abspath(os.fspath(job))
        out_dir = os.path.abspath(os.fspath(output_dir)) if output_dir else ""
        futures = [client.submit(run_shard, job, out_dir, k, shards, set, pure=False,
                                 retries=retries)
                   for k in range(1, shards + 1)]
        shard_of = {f.key: k for k, f in enumerate(futures)}
        manifests = [None] * shards
        # Each manifest's path is taken as its shard ends and the task then released: Dask
        # recomputes the held results of a lost worker, so a worker lost late would otherwise
        # take all its finished shards with it. Only the shards it was computing are run again.
        done = as_completed(futures, with_results=True)
        del futures
        for future, path in done:
            manifests[shard_of[future.key]] = path
        if output is None:
            import json
            with open(manifests[0]) as f:
                name = json.load(f)["output"]
            output = os.path.join(os.path.dirname(manifests[0]), name)
        _trellis.merge_shards(list(manifests), os.fspath(output))
        return os.fspath(output)
    finally:
        for x in reversed(own):
            x.close()

