"""The pieces of ``--dask`` that need no cluster: the address's form, the writer's fence, the
removal of a run's temporary files, and the check of a task's report against the disk (tests/test_dask_faults.py runs
them on real clusters)."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from conftest import FIXTURES

from depixel.errors import OutputError
from depixel.files.output import STILL_WANTED, commit, remove_temporary_in, stage, temporary_path, write_atomic
from depixel.options import ConvertOptions
from depixel_cli.convert.batch import CANCELLED, INTERRUPTED, Job, Options, Outcome, run_job, totals_line
from depixel_cli.dask.batch import _checked
from depixel_cli.dask.cluster import DaskError, checked_address


@pytest.mark.parametrize("address", ["", "tcp://", "tcp://h:8786/extra", "tcp://h:", ":8786", "tcp://tcp://h:1",
                                     "h h:1", "tcp://[::1", "tcp://h:8786?x=1", "user@h:1"])
def test_a_malformed_address_is_refused_before_dask_is_imported(address):
    with pytest.raises(DaskError, match="not a scheduler address"):
        checked_address(address)


@pytest.mark.parametrize(("address", "normal"), [
    ("h", "tcp://h:8786"), ("h:1234", "tcp://h:1234"), ("TCP://h.example.org:1", "tcp://h.example.org:1"),
    ("tcp://10.0.0.2:8786", "tcp://10.0.0.2:8786"), ("tcp://[::1]:8786", "tcp://[::1]:8786"),
    ("[fe80::1]", "tcp://[fe80::1]:8786"), ("dask_scheduler:8786", "tcp://dask_scheduler:8786")])
def test_a_well_formed_address_is_normalised(address, normal):
    pytest.importorskip("distributed", reason="the dask extra is not installed")
    assert checked_address(address)[0] == normal


@pytest.mark.parametrize(("address", "reason"), [("http://h:80", "unknown scheme http://"),
                                                 ("inproc://h:1", "unknown scheme inproc://"),
                                                 ("tcp://h:0", "port 0 is out of range"),
                                                 ("tcp://h:65536", "port 65536 is out of range")])
def test_schemes_and_ports_dask_cannot_use_are_refused(address, reason):
    with pytest.raises(DaskError, match=reason):
        checked_address(address)


def test_the_temporary_files_of_a_run_are_removed_from_a_folder_and_no_others(tmp_path):
    token, other = "0123456789ab", "ba9876543210"
    ours = [temporary_path(tmp_path / name, token, pid) for name, pid in (("a.svg", 11), ("b.svg", 12), ("a.svg", 13))]
    ours.append(ours[0].with_name(ours[0].name[:-4] + "-1.tmp"))  # a second writer of a.svg in one process
    theirs = [temporary_path(tmp_path / "a.svg", other, 11), tmp_path / ".a.svg.mine.tmp",
              tmp_path / f".a.svg.depixel-11-{token}.tmp.bak", tmp_path / f"a.svg.depixel-11-{token}.tmp",
              tmp_path / "a.svg"]
    for path in ours + theirs:
        path.write_text("x")
    assert sorted(remove_temporary_in(tmp_path, token)) == sorted(ours)
    assert sorted(tmp_path.iterdir()) == sorted(theirs)
    assert remove_temporary_in(tmp_path, "not a token") == [] and remove_temporary_in(tmp_path / "gone", token) == []


def test_a_stopped_task_renames_nothing_and_leaves_no_temporary_file(tmp_path):
    """The fence: once the batch's marker is gone, the outputs already there stay as they
    were, and the temporary files are removed (a frame set: none of them)."""
    targets = [tmp_path / "a.svg", tmp_path / "b.svg"]
    targets[0].write_text("before")
    scope = STILL_WANTED.set(lambda: False)
    try:
        with pytest.raises(OutputError, match="its batch was stopped"):
            write_atomic(targets[0], "after")
        with pytest.raises(OutputError, match="its batch was stopped"):
            commit([stage(target, "after") for target in targets])
    finally:
        STILL_WANTED.reset(scope)
    assert targets[0].read_text() == "before"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.svg"]
    scope = STILL_WANTED.set(lambda: True)
    try:
        write_atomic(targets[1], "after")
    finally:
        STILL_WANTED.reset(scope)
    assert targets[1].read_text() == "after"


def job_in(tmp_path: Path, force: bool = False) -> Job:
    source = tmp_path / "heart.png"
    shutil.copy(FIXTURES / "heart.png", source)
    options = Options(ConvertOptions.build(max_pixels=None), ("svg",), "first", force=force)
    return Job(source, tmp_path / "heart.svg", options)


def test_a_reported_output_that_is_not_here_is_a_failure(tmp_path):
    job = job_in(tmp_path)
    claimed = Outcome(job.source, job.output, written=[job.output])
    checked = _checked(claimed, job, "tcp://w:1", begun=0)
    assert checked.error is not None and checked.written == []
    assert "heart.svg: Dask worker tcp://w:1 reported it converted, but the file is not there" in checked.error


def test_a_reported_output_with_another_stamp_is_a_failure(tmp_path):
    job = job_in(tmp_path)
    job.output.write_text("<svg><!-- depixel-options:0000000000000000 --></svg>")
    claimed = Outcome(job.source, job.output, written=[job.output])
    checked = _checked(claimed, job, "tcp://w:1", begun=0)
    assert checked.error is not None and "there is not the file it wrote" in checked.error


@pytest.mark.parametrize("force", [False, True])
def test_a_reported_output_that_is_here_stands_and_one_made_by_a_dead_try_counts_as_converted(tmp_path, force):
    job = job_in(tmp_path, force)
    done = run_job(job)
    assert done.written == [job.output]
    assert _checked(done, job, "tcp://w:1", begun=0).error is None
    # the retry of a task whose worker died after the rename finds the output up to date
    retried = Outcome(job.source, job.output, up_to_date=[job.output])
    checked = _checked(retried, job, "tcp://w:1", begun=job.output.stat().st_mtime_ns)
    assert checked.error is None and checked.written == [job.output] and checked.up_to_date == []
    # written before this batch began: still skipped
    skipped = _checked(Outcome(job.source, job.output, up_to_date=[job.output]), job, "tcp://w:1",
                       begun=job.output.stat().st_mtime_ns + 1)
    assert skipped.written == [] and skipped.up_to_date == [job.output]


def test_the_summary_line_counts_the_files_a_stopped_batch_did_not_do():
    """A --dask batch stopped without a signal (scheduler lost, no worker) says what it did
    not do, as an interrupted one does."""
    outcomes = [Outcome(Path("a.png"), written=[Path("a.svg")]), Outcome(Path("b.png"), state=INTERRUPTED),
                Outcome(Path("c.png"), state=CANCELLED), Outcome(Path("d.png"), state=CANCELLED)]
    assert totals_line(outcomes, 1.0) == ("4 files: 1 converted, 0 up to date, 0 kept, 0 failed, 1 abandoned, "
                                          "2 not started in 1.0 s")
    assert totals_line(outcomes, 1.0, interrupted=True).endswith("2 not started (interrupted) in 1.0 s")
