"""The Python call against the command on the vendored flight-test data (BENCHMARKS.md).

    python python/benches/gaps_vs_cli.py AEROSID [REPEATS]

For each flight, `aerosid.gaps(..., out=DIR)` in this process and `AEROSID gaps --data ... --out
DIR` as a child process, interleaved, REPEATS times each (default 5); both write the same report
and figures. Times are CPU seconds (this process's, the child's), which another build on a shared
machine inflates far less than wall-clock time; the median of the repeats is reported, and the
ratio Python / command per flight and over all flights.
"""

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import aerosid

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tool" / "data"
FLIGHTS = [
    (DATA / "flight" / "hfb320_1_10.asc", DATA / "maps" / "hfb320.map"),
    (DATA / "flight" / "fAttasAil1_pqrDot.asc", DATA / "maps" / "attas.map"),
    (DATA / "flight" / "fAttasElv1_pqrDot.asc", DATA / "maps" / "attas.map"),
    (DATA / "flight" / "fAttasRud1_pqrDot.asc", DATA / "maps" / "attas.map"),
    (DATA / "flight" / "totter_lon_020213f1_018_fdata.asc", DATA / "maps" / "twin_otter.map"),
]


def children_cpu() -> float:
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def main() -> None:
    exe = sys.argv[1]
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    total_py, total_cli = 0.0, 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for data, m in FLIGHTS:
            py, cli = [], []
            for _ in range(repeats):
                t = time.process_time()
                aerosid.gaps(data, aircraft=m, out=os.path.join(tmp, "py"))
                py.append(time.process_time() - t)
                c = children_cpu()
                subprocess.run(
                    [exe, "gaps", "--data", str(data), "--with", str(m), "--out", os.path.join(tmp, "cli")],
                    check=True,
                    capture_output=True,
                )
                cli.append(children_cpu() - c)
            p, q = statistics.median(py), statistics.median(cli)
            total_py += p
            total_cli += q
            print(f"{data.name:<36} python {p:7.3f} s   command {q:7.3f} s   ratio {p / q:5.3f}")
    print(f"{'all five':<36} python {total_py:7.3f} s   command {total_cli:7.3f} s   ratio {total_py / total_cli:5.3f}")


if __name__ == "__main__":
    main()
