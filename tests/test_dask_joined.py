"""``depixel convert --dask``: a worker that joins the cluster during the batch is checked
when it is first seen, as every worker was before the first task. One of another depixel
version is named in one line and its tasks are sent to the workers that passed; no file is
reported failed with a false reason. Runs the command on a real ``LocalCluster``, joined
mid-batch by a ``dask worker`` process made faulty by tests/dask_worker_preload.py."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from test_dask_faults import PRELOAD, command, local_cluster, sprites, stamped, tiled
from test_faults import wait_for_outputs

from depixel.files import stamp

distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")


def test_a_worker_of_another_version_joining_mid_batch_is_checked_and_left_out(tmp_path):
    big = tmp_path / "big.png"
    tiled(big, 6)
    out = tmp_path / "out"
    with local_cluster(1) as local:
        proc = subprocess.Popen(command(str(sprites(tmp_path / "in", 30, big)), "--out-dir", str(out), "--json",
                                        "--dask", local.scheduler_address),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wait_for_outputs(out, proc, count=2)
        joined = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", local.scheduler_address,
                                   "--nthreads", "1", "--no-dashboard", "--preload", str(PRELOAD)],
                                  env={**os.environ, "DEPIXEL_TEST_WORKER": "other-version"},
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            stdout, stderr = proc.communicate(timeout=300)
        finally:
            joined.terminate()
            joined.wait(timeout=60)
    report = json.loads(stdout)
    assert proc.returncode == 0 and report["failed"] == [], stderr
    assert report["ok"] == 30 and stamped(out) == {f"s{i:03d}.svg" for i in range(30)}
    warnings = stderr.splitlines()
    assert len(warnings) == 1 and "has depixel 0.0.0+other" in warnings[0], stderr
    assert "joined during the batch" in warnings[0]
    # every output made by this version (the other one's, stamped with its version, made again)
    assert len({stamp.read(p).options for p in out.glob("*.svg")}) == 1
