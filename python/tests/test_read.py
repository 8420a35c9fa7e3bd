"""aerosid.read: any flight file into one SI table on a uniform time base."""

import sys

import numpy as np
import pandas as pd
import pytest

import aerosid
from conftest import FLIGHT, LOGS, MAPS


def test_a_ulog_reads_without_an_aircraft_file_into_a_uniform_table():
    df = aerosid.read(LOGS / "log_52_2021-5-22-12-42-56.ulg")
    assert isinstance(df, pd.DataFrame)
    assert df.index.name == "t_s"
    dt = np.diff(df.index.to_numpy())
    # A uniform time base: every step within 1 % of the median (what the analysis requires).
    assert np.all(np.abs(dt - np.median(dt)) <= 0.01 * np.median(dt))
    assert {"roll_rate_rad_s", "pitch_rate_rad_s", "accel_z_mps2"} <= set(df.columns)
    assert np.isfinite(df.to_numpy()).all()
    assert df.attrs["units"]["pitch_rate_rad_s"] == "rad/s"
    assert df.attrs["aircraft_unknown"] is True
    assert "ULog" in df.attrs["format"]
    # Specific force along z in flight is near −g on average (FRD body axes, SI units).
    assert -12.0 < df["accel_z_mps2"].mean() < -7.0


def test_a_column_mapped_file_reads_in_si_units():
    df = aerosid.read(FLIGHT / "hfb320_1_10.asc", aircraft=MAPS / "hfb320.map")
    assert len(df) > 500
    assert (df["airspeed_mps"] > 50).all()
    # α of a transport aircraft in this manoeuvre: within ±20° (radians, not degrees).
    assert df["alpha_rad"].abs().max() < np.radians(20)


def test_every_column_name_carries_its_unit():
    cols = aerosid.columns()
    assert cols["airspeed_mps"] == "m/s"
    assert cols["alpha_rad"] == "rad"
    assert cols["throttle"] == "1"


def test_a_file_that_needs_a_map_says_so():
    with pytest.raises(aerosid.AerosidError, match=r"needs a companion file \(`--with`\)"):
        aerosid.read(FLIGHT / "hfb320_1_10.asc")


def test_a_file_that_is_not_a_log_names_itself(tmp_path):
    bad = tmp_path / "bad.ulg"
    bad.write_text("not a ULog")
    with pytest.raises(aerosid.AerosidError, match=r"bad\.ulg: not a ULog"):
        aerosid.read(bad)
    # AerosidError is a ValueError: code catching ValueError catches it.
    with pytest.raises(ValueError):
        aerosid.read(bad)


def test_options_are_checked():
    with pytest.raises(TypeError, match="unknown option"):
        aerosid.read(LOGS / "log_52_2021-5-22-12-42-56.ulg", frm=3)
    with pytest.raises(aerosid.AerosidError, match="must be before"):
        aerosid.read(LOGS / "log_52_2021-5-22-12-42-56.ulg", from_s=10.0, to_s=5.0)


def test_without_pandas_a_dict_of_arrays(monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)
    d = aerosid.read(FLIGHT / "hfb320_1_10.asc", aircraft=MAPS / "hfb320.map")
    assert isinstance(d, dict)
    assert d["t_s"].dtype == np.float64
    assert len(d["airspeed_mps"]) == len(d["t_s"])
