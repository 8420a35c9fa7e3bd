"""``aerosid batch`` on a Dask cluster: one task per log, the same folders and the same summary.

    python -m aerosid.dask_batch --out DIR [--scheduler ADDRESS] [--with MAP] [--force] FILES...

Without ``--scheduler`` a LocalCluster on this machine runs the logs (``--workers`` processes, one
thread each: the analysis releases the GIL, but a process per worker keeps one log's memory from
another's). With an address (``tcp://host:8786``, as ``dask scheduler`` or dask-jobqueue /
dask-kubernetes print it), the logs run on that cluster's workers, which must see the files and
``DIR`` at the same paths (a shared file system) and have this package installed.

Each task calls the same Rust function as ``aerosid batch`` (``aerosid.batch_one``): the folder
of a log, its report and its summary row are the command's. The summary is written here, in the
order the files were given. The exit code is 0 when every log was analysed or read back, 1 when
any row is an error.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any, Dict, List, Optional, Sequence

import aerosid


def _task(file: str, out: str, aircraft: Optional[str], force: bool) -> Dict[str, Any]:
    # Imported on the worker: the task ships a name, not the extension module.
    import aerosid as a

    return a.batch_one(file, out, aircraft=aircraft, force=force)


def run(
    files: Sequence[str],
    out: str,
    *,
    aircraft: Optional[str] = None,
    force: bool = False,
    client: Any = None,
) -> List[Dict[str, Any]]:
    """Runs the batch on ``client`` (a ``distributed.Client``), writes ``out/summary.csv`` and
    ``out/summary.jsonl``, and returns the rows in the order of ``files``."""
    if not files:
        raise ValueError("no log given: name one or more files")
    out = os.path.abspath(out)
    os.makedirs(out, exist_ok=True)
    paths = [os.path.abspath(f) for f in files]
    aircraft = os.path.abspath(aircraft) if aircraft else None
    futures = client.map(_task, paths, out=out, aircraft=aircraft, force=force, pure=False)
    rows = client.gather(futures)
    # The rows name each file as it was given, as the command's do.
    for row, given in zip(rows, files):
        row["file"] = given
    aerosid.write_summary(out, rows)
    return rows


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m aerosid.dask_batch",
        description="The model-gap analysis of many logs on a Dask cluster (aerosid batch's folders and summary).",
    )
    p.add_argument("files", nargs="+", metavar="FILES", help="the logs")
    p.add_argument("--out", required=True, metavar="DIR", help="folder of the per-log folders and the summary")
    p.add_argument("--scheduler", metavar="ADDRESS", help="a running scheduler (default: a LocalCluster here)")
    p.add_argument("--workers", type=int, default=None, metavar="N", help="LocalCluster worker processes (default: the cores)")
    p.add_argument("--with", dest="aircraft", metavar="MAP_OR_AIRCRAFT", help="the column map or aircraft file of every log")
    p.add_argument("--force", action="store_true", help="analyse every log again, even when its report.json exists")
    a = p.parse_args(argv)
    from distributed import Client, LocalCluster

    if a.scheduler:
        client = Client(a.scheduler)
        cluster = None
    else:
        cluster = LocalCluster(
            n_workers=a.workers or os.cpu_count() or 1, threads_per_worker=1, processes=True, dashboard_address=":0"
        )
        client = Client(cluster)
    try:
        rows = run(a.files, a.out, aircraft=a.aircraft, force=a.force, client=client)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    for r in rows:
        what = r["top_cause"] if r["status"] == "verdict" and r["top_cause"] else r["reason"].split("\n")[0]
        resumed = " (resumed)" if r.get("resumed") else ""
        print(f"{r['status']:<10} {r['file']}{resumed}: {what}")
    print(f"summary: {os.path.join(a.out, 'summary.csv')} and {os.path.join(a.out, 'summary.jsonl')}")
    return 1 if any(r["status"] == "error" for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
