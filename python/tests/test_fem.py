"""aerosid.fem and aerosid.predict: the identification.json and prediction.json of the commands."""

import json
import subprocess

import pytest

import aerosid
from conftest import ATTAS, MAPS, MODELS


def test_fem_fixes_a_parameter_and_predict_reapplies_the_model(tmp_path):
    # The HFB-320 model file with Cmq fixed at the published filter-error value (as the Rust
    # workflow test): Cmq exactly that value without σ, the ten others estimated.
    r = aerosid.fem(MODELS / "hfb320.toml", fix={"Cmq": -34.7098}, out=tmp_path)
    params = {p["name"]: p for p in r["parameters"]}
    assert params["Cmq"]["fixed"] and params["Cmq"]["value"] == -34.7098 and params["Cmq"]["sigma"] is None
    assert sum(p["sigma"] is not None for p in r["parameters"]) == 10
    assert "Cmq" in r["text"]
    # predict on the same record reproduces the identification's fit (the same simulation; the
    # bound is rounding of a JSON round trip of the parameters).
    p = aerosid.predict(tmp_path / "identification.json")
    for a, b in zip(p["fit"], r["fit"]):
        assert a["name"] == b["name"]
        assert abs(a["r2"] - b["r2"]) < 1e-12


def test_fem_is_the_commands(aerosid_exe, tmp_path):
    r = aerosid.fem(MODELS / "hfb320.toml")
    subprocess.run(
        [aerosid_exe, "fem", "--model", str(MODELS / "hfb320.toml"), "--out", str(tmp_path)],
        check=True,
        capture_output=True,
    )
    c = json.loads((tmp_path / "identification.json").read_text())
    assert [(p["name"], p["value"], p["sigma"]) for p in r["parameters"]] == [
        (p["name"], p["value"], p["sigma"]) for p in c["parameters"]
    ]


def test_predict_with_a_gap_report(tmp_path):
    aerosid.gaps(ATTAS[1], aircraft=MAPS / "attas.map", out=tmp_path / "gaps")
    p = aerosid.predict(tmp_path / "gaps" / "report.json", ATTAS[0], aircraft=MAPS / "attas.map")
    assert p["coefficients"]
    with pytest.raises(aerosid.AerosidError, match="exactly one data file"):
        aerosid.predict(tmp_path / "gaps" / "report.json", ATTAS[:2], aircraft=MAPS / "attas.map")


def test_a_missing_model_file_is_named(tmp_path):
    with pytest.raises(aerosid.AerosidError, match="nope.toml"):
        aerosid.fem(tmp_path / "nope.toml")
