"""``depixel convert --dask``: the batch on a real Dask cluster (a LocalCluster this module
starts), compared with ``-j 1``. Skipped when the extra (``pip install "depixel[dask]"``)
is not installed."""
from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import FIXTURES
from test_dask_faults import sprites, stamped
from test_faults import batch_folder, wait_for_outputs

from depixel_cli.main import main
from depixel_cli.options import Exit

distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")


@pytest.fixture(scope="module")
def scheduler():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster:
        yield cluster.scheduler_address


def folder_with_a_bad_file(tmp_path: Path) -> Path:
    src = tmp_path / "in"
    (src / "sub").mkdir(parents=True)
    for name in ("heart.png", "leaf.png", "heart_beat.gif"):
        shutil.copy(FIXTURES / name, src / name)
    shutil.copy(FIXTURES / "potion_rgba.png", src / "sub" / "potion.png")
    (src / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    return src


def run_json(capsys, argv) -> tuple[int, dict]:
    code = main(argv)
    return code, json.loads(capsys.readouterr().out)


def test_dask_batch_is_byte_identical_to_one_process(tmp_path, capsys, scheduler):
    src = folder_with_a_bad_file(tmp_path)
    common = ["convert", str(src), "-r", "--frames", "all", "--json", "--stage", "splines"]
    code_j1, local = run_json(capsys, common + ["--out-dir", str(tmp_path / "j1"), "-j", "1"])
    code_dask, remote = run_json(capsys, common + ["--out-dir", str(tmp_path / "dask"), "--dask", scheduler])
    assert code_j1 == code_dask == Exit.FAILED

    def files(root: Path) -> dict[str, bytes]:
        return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}

    assert files(tmp_path / "j1") == files(tmp_path / "dask")
    assert set(files(tmp_path / "dask")) == {"heart.svg", "leaf.svg", "heart_beat-000.svg", "heart_beat-001.svg",
                                             "sub/potion.svg"}
    # the same report, with the command's own (relative) names
    for report in (local, remote):
        report.pop("seconds")
        for o in report["outputs"]:
            o["output"] = Path(o["output"]).name
            o.pop("seconds", None)  # each output's time varies
    assert local == remote
    assert [f["input"] for f in remote["failed"]] == [str(src / "broken.png")]

    # a rerun on the cluster finds everything up to date
    code, again = run_json(capsys, common + ["--out-dir", str(tmp_path / "dask"), "--dask", scheduler])
    assert {o["status"] for o in again["outputs"] if o["status"] != "failed"} == {"up-to-date"}
    # and --force converts every file again (checked on disk like any other result)
    code, forced = run_json(capsys, common + ["--out-dir", str(tmp_path / "dask"), "--dask", scheduler, "--force"])
    assert [f["input"] for f in forced["failed"]] == [str(src / "broken.png")]
    assert forced["ok"] == remote["ok"] and {o["status"] for o in forced["outputs"]} == {"converted", "failed"}


def test_dask_batch_stops_on_ctrl_c(tmp_path, scheduler):
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "depixel", "convert", str(batch_folder(tmp_path, 60)),
                             "--out-dir", str(out), "--json", "--dask", scheduler],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for_outputs(out, proc)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr
    report = json.loads(stdout)
    assert report["interrupted"] is True
    statuses = [o["status"] for o in report["outputs"]]
    assert len(statuses) == 60 and "cancelled" in statuses


def test_dask_needs_out_dir(capsys, scheduler):
    with pytest.raises(SystemExit) as exit_info:
        main(["convert", str(FIXTURES / "heart.png"), "-o", "x.svg", "--dask", scheduler])
    assert exit_info.value.code == Exit.USAGE
    assert "--dask" in capsys.readouterr().err


def test_two_batches_on_one_scheduler_keep_their_own_files(tmp_path, scheduler):
    """Two batches at once on one scheduler, with the same file names (so the same indices
    and names in their tasks). Before: both reported 20 converted, one folder stayed empty
    and its report named the other's outputs (the scheduler gave one batch the other's
    finished tasks)."""
    procs = {}
    for name in "ab":
        src = sprites(tmp_path / f"in_{name}", 20)
        procs[name] = subprocess.Popen([sys.executable, "-m", "depixel", "convert", "-q", str(src), "--out-dir",
                                        str(tmp_path / f"out_{name}"), "--json", "--dask", scheduler],
                                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for name, proc in procs.items():
        stdout, stderr = proc.communicate(timeout=120)
        assert proc.returncode == 0, stderr
        report = json.loads(stdout)
        assert report["ok"] == 20
        assert {Path(o["output"]).parent for o in report["outputs"]} == {tmp_path / f"out_{name}"}
        assert stamped(tmp_path / f"out_{name}") == {f"s{i:03d}.svg" for i in range(20)}


def test_outputs_beside_their_inputs(tmp_path, capsys, scheduler):
    """Without --out-dir each output is written beside its input; the run marker and the
    probe's file go beside the first output, and are gone at the end."""
    src = sprites(tmp_path / "in", 3)
    code, report = run_json(capsys, ["convert", "-q", str(src), "--json", "--dask", scheduler])
    assert code == 0 and report["ok"] == 3
    assert sorted(p.name for p in src.iterdir()) == ["s000.png", "s000.svg", "s001.png", "s001.svg", "s002.png",
                                                    "s002.svg"]


def test_dask_animates_one_file_per_input_as_one_process_does(tmp_path, capsys, scheduler):
    src = folder_with_a_bad_file(tmp_path)
    common = ["convert", str(src), "-r", "--animate", "--json", "--stage", "splines"]
    code_j1, _ = run_json(capsys, common + ["--out-dir", str(tmp_path / "j1"), "-j", "1"])
    code_dask, remote = run_json(capsys, common + ["--out-dir", str(tmp_path / "dask"), "--dask", scheduler])
    assert code_j1 == code_dask == Exit.FAILED  # broken.png

    def files(root: Path) -> dict[str, bytes]:
        return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}

    assert files(tmp_path / "j1") == files(tmp_path / "dask")
    assert set(files(tmp_path / "dask")) == {"heart.svg", "leaf.svg", "heart_beat.svg", "sub/potion.svg"}
    assert files(tmp_path / "dask")["heart_beat.svg"].count(b'inkscape:groupmode="layer"') == 2
