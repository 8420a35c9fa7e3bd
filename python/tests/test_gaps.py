"""aerosid.gaps: the report.json of `aerosid gaps`, from a file, a list of files pooled, or a frame."""

import json
import subprocess

import pytest

import aerosid
from conftest import AIRCRAFT, ATTAS, FLIGHT, LOGS, MAPS

ELV = ATTAS[1]
ATTAS_MAP = MAPS / "attas.map"


def cli_report(exe, tmp_path, data, with_=None):
    files = data if isinstance(data, list) else [data]
    args = [exe, "gaps", "--data", *map(str, files), "--out", str(tmp_path / "cli")]
    if with_ is not None:
        args += ["--with", str(with_)]
    subprocess.run(args, check=True, capture_output=True)
    return json.loads((tmp_path / "cli" / "report.json").read_text())


def test_the_report_is_the_commands(aerosid_exe, tmp_path):
    r = aerosid.gaps(ELV, aircraft=ATTAS_MAP, out=tmp_path / "py")
    c = cli_report(aerosid_exe, tmp_path, ELV, ATTAS_MAP)
    assert r["schema"] == "aerosid-gaps/3"
    # The same analysis: the same verdict, causes and fitted parameters.
    for key in ("verdict", "named", "top_cause", "data_quality", "coefficients"):
        assert r[key] == c[key], key
    # out= writes the command's files.
    assert json.loads((tmp_path / "py" / "report.json").read_text()) == r
    assert (tmp_path / "py" / "report.txt").is_file()
    assert list((tmp_path / "py").glob("gap_*.svg"))


def test_a_list_of_one_flight_is_that_flight():
    log = LOGS / "log_52_2021-5-22-12-42-56.ulg"
    r = aerosid.gaps([log])
    assert r["data_quality"]["supports_verdict"] is False
    assert r == aerosid.gaps(log)


def test_a_list_pools_its_manoeuvres_as_the_commands_repeated_data(aerosid_exe, tmp_path):
    # The three ATTAS manoeuvres (aileron, elevator, rudder) in one analysis, given in an order
    # other than the canonical one: the command pools them whatever the order.
    files = [ATTAS[2], ATTAS[0], ATTAS[1]]
    r = aerosid.gaps(files, aircraft=ATTAS_MAP)
    c = cli_report(aerosid_exe, tmp_path, files, ATTAS_MAP)
    assert len(r["manoeuvres"]) == 3
    for key in ("verdict", "named", "top_cause", "data_quality", "coefficients", "manoeuvres"):
        assert r[key] == c[key], key
    # A manoeuvre cut to a segment is the command's --segment.
    seg = aerosid.gaps(ATTAS[:2], aircraft=ATTAS_MAP, segments=[(0.0, 20.0)])
    assert [m["span_s"][1] - m["span_s"][0] <= 20.0 for m in seg["manoeuvres"]] == [True, True]


def test_a_list_with_a_frame_or_no_file_is_refused():
    df = aerosid.read(ELV, aircraft=ATTAS_MAP)
    with pytest.raises(ValueError, match="files to pool"):
        aerosid.gaps([ELV, df], aircraft=ATTAS_MAP)
    with pytest.raises(ValueError, match="empty list"):
        aerosid.gaps([], aircraft=ATTAS_MAP)


def test_a_frame_of_read_is_analysed(tmp_path):
    df = aerosid.read(ELV, aircraft=ATTAS_MAP)
    r = aerosid.gaps(df, aircraft=AIRCRAFT / "attas.aircraft")
    assert r["schema"] == "aerosid-gaps/3"
    assert r["source"] == f"DataFrame of {df.attrs['source']}"
    assert [c["name"] for c in r["coefficients"]] == [
        c["name"] for c in aerosid.gaps(ELV, aircraft=ATTAS_MAP)["coefficients"]
    ]
    # Without an aircraft file the coefficients cannot be scaled: no verdict, and it says why.
    r = aerosid.gaps(df.reset_index())
    assert r["data_quality"]["supports_verdict"] is False


def test_a_frame_with_a_column_aerosid_does_not_know_is_refused():
    df = aerosid.read(ELV, aircraft=ATTAS_MAP)
    df["my_column"] = 0.0
    with pytest.raises(aerosid.AerosidError, match="column `my_column` is not a channel"):
        aerosid.gaps(df, aircraft=AIRCRAFT / "attas.aircraft")
    with pytest.raises(aerosid.AerosidError, match="must be an aircraft file"):
        aerosid.gaps(df.drop(columns="my_column"), aircraft=ATTAS_MAP)


def test_errors_carry_the_commands_messages(tmp_path):
    with pytest.raises(aerosid.AerosidError, match=r"needs aircraft=MAP_OR_AIRCRAFT"):
        aerosid.gaps(FLIGHT / "hfb320_1_10.asc")
    with pytest.raises(aerosid.AerosidError, match="air_data `wind`"):
        aerosid.gaps(ELV, aircraft=ATTAS_MAP, air_data="wind")
    with pytest.raises(aerosid.AerosidError, match="alpha"):
        aerosid.gaps(ELV, aircraft=ATTAS_MAP, alpha=2.0)
    with pytest.raises(aerosid.AerosidError, match="low_rate_method `kalman`"):
        aerosid.gaps(ELV, aircraft=ATTAS_MAP, low_rate_method="kalman")
    with pytest.raises(TypeError, match="unknown option"):
        aerosid.gaps(ELV, aircraft=ATTAS_MAP, alpah=0.05)


def test_a_log_too_short_is_a_report_with_no_verdict(tmp_path):
    # Readable but too short: a report (status no_verdict, the reasons), as the command writes it.
    for out in (None, tmp_path):
        r = aerosid.gaps(LOGS / "pymavlink_test.BIN", out=out)
        assert r["status"] == "no_verdict"
        assert any("41 samples" in x for x in r["reasons"]), r["reasons"]
    assert json.loads((tmp_path / "report.json").read_text())["status"] == "no_verdict"
