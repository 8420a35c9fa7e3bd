"""Shared paths: the vendored data of the source checkout and the `aerosid` command."""

import os
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tool" / "data"
FLIGHT = DATA / "flight"
LOGS = DATA / "logs"
MAPS = DATA / "maps"
AIRCRAFT = DATA / "aircraft"
MODELS = ROOT / "tool" / "models"

#: The vendored autopilot logs (read without an aircraft file).
LOG_FILES = sorted(p for p in LOGS.iterdir() if p.suffix.lower() in (".ulg", ".bin"))
#: The ATTAS flight-test manoeuvres (with maps/attas.map).
ATTAS = [FLIGHT / f for f in ("fAttasAil1_pqrDot.asc", "fAttasElv1_pqrDot.asc", "fAttasRud1_pqrDot.asc")]


@pytest.fixture(scope="session")
def aerosid_exe() -> str:
    """The `aerosid` command: $AEROSID, else the cargo build in target/debug, else PATH."""
    candidates = [os.environ.get("AEROSID"), str(ROOT / "target" / "debug" / "aerosid"), shutil.which("aerosid")]
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    pytest.fail("no `aerosid` command: build it (cargo build -p aerosid) or set AEROSID")
