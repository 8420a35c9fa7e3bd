"""The Dask batch on a two-worker LocalCluster against `aerosid batch`: row by row the same files,
folders, statuses and top causes (the seconds differ)."""

import json
import subprocess

import pytest

from conftest import ATTAS, LOG_FILES, MAPS

distributed = pytest.importorskip("distributed")

from aerosid import dask_batch  # noqa: E402


def rows(out):
    return [json.loads(l) for l in (out / "summary.jsonl").read_text().splitlines()]


def key(r):
    return (r["file"], r["folder"], r["status"], r["top_cause"])


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_the_logs_and_a_bad_file_as_aerosid_batch(client, aerosid_exe, tmp_path):
    bad = tmp_path / "not_a_log.ulg"
    bad.write_text("not a log")
    files = [str(f) for f in LOG_FILES] + [str(bad)]
    cli = subprocess.run(
        [aerosid_exe, "batch", "--out", str(tmp_path / "cli"), "--jobs", "2", *files], capture_output=True, text=True
    )
    assert cli.returncode == 1, cli.stderr
    got = dask_batch.run(files, str(tmp_path / "dask"), client=client)
    assert [key(r) for r in rows(tmp_path / "dask")] == [key(r) for r in rows(tmp_path / "cli")]
    assert [key(r) for r in got] == [key(r) for r in rows(tmp_path / "cli")]
    assert {r["status"] for r in got} >= {"no_verdict", "error"}
    # The CSV has the command's header.
    assert (tmp_path / "dask" / "summary.csv").read_text().splitlines()[0] == "file,folder,status,top_cause,reason,seconds"


def test_flight_test_data_with_a_map_and_resume(client, aerosid_exe, tmp_path):
    files = [str(f) for f in ATTAS]
    m = str(MAPS / "attas.map")
    subprocess.run([aerosid_exe, "batch", "--out", str(tmp_path / "cli"), "--with", m, *files], check=True, capture_output=True)
    got = dask_batch.run(files, str(tmp_path / "dask"), aircraft=m, client=client)
    assert [key(r) for r in got] == [key(r) for r in rows(tmp_path / "cli")]
    assert all(not r["resumed"] for r in got)
    again = dask_batch.run(files, str(tmp_path / "dask"), aircraft=m, client=client)
    assert all(r["resumed"] for r in again)
    assert [key(r) for r in again] == [key(r) for r in got]


def test_the_command_line(tmp_path):
    bad = tmp_path / "x.bin"
    bad.write_bytes(b"\x00" * 10)
    code = dask_batch.main(["--out", str(tmp_path / "out"), "--workers", "1", str(bad)])
    assert code == 1
    assert rows(tmp_path / "out")[0]["status"] == "error"
