"""`aerotruth diagnose TRAFFIC` on multi-aircraft traffic (the independent generator,
tests/traffic_generator.py), without a campaign: the consensus observation table is made on
the way and diagnosed per aircraft; one aircraft alone is refused in one line."""

from __future__ import annotations

import json

import pandas as pd
from traffic_generator import make_traffic

from aerotruth.app.cli import main


def test_traffic_is_diagnosed_against_the_consensus_without_a_campaign(tmp_path, capsys):
    traffic, offsets = make_traffic(n_aircraft=24, seed=3, minutes=40)
    traffic.to_csv(tmp_path / "hour.csv", index=False)
    assert main(["diagnose", str(tmp_path / "hour.csv"), "--out", str(tmp_path / "d")]) == 0
    said = capsys.readouterr().out
    assert "observation table" in said and "gated reports of" in said
    doc = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    assert doc["kind"] == "observation_table"
    # no campaign, no extended campaign to write
    assert not (tmp_path / "d" / "extended_model.yaml").exists()
    # each aircraft's offset in the model's fit follows the generator's (relative to the fleet)
    fit = pd.DataFrame.from_dict(doc["baseline"]["model_fit"], orient="index")
    a = fit["A_deg"].astype(float)
    true = pd.Series(offsets).reindex(a.index)
    assert a.notna().sum() >= 15
    assert (a - a.mean()).corr(true - true.mean()) > 0.95


def test_one_aircrafts_traffic_is_refused_in_one_line(tmp_path, capsys):
    traffic, _ = make_traffic(n_aircraft=1, seed=0, minutes=25)
    traffic.to_csv(tmp_path / "one.csv", index=False)
    assert main(["diagnose", str(tmp_path / "one.csv"), "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "needs other aircraft" in err[0], err


def test_heading_fit_on_traffic_says_how_to_make_the_table(tmp_path, capsys):
    traffic, _ = make_traffic(n_aircraft=3, seed=0, minutes=25)
    traffic.to_csv(tmp_path / "hour.csv", index=False)
    assert main(["heading", "fit", str(tmp_path / "hour.csv"), "--out", str(tmp_path / "fit")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "traffic of 3 aircraft, not an observation table" in err[0], err
    assert "aerotruth reports" in err[0] and "--reference consensus" in err[0]
