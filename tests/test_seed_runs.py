"""validation/seed_runs.py: the seed grid's parameter edits reach the campaign that runs."""

import sys
from pathlib import Path

import pytest
import yaml

from aerotruth.sim.campaign_loader import load_campaign

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "validation"))
import seed_runs  # noqa: E402


def test_seed_ranges_and_lists():
    assert seed_runs.parse_seeds("2010-2012,2015") == [2010, 2011, 2012, 2015]
    with pytest.raises(SystemExit, match="--seeds"):
        seed_runs.parse_seeds("20x")


def test_a_set_by_list_name_changes_exactly_that_parameter(tmp_path):
    doc = yaml.safe_load((ROOT / "campaigns/penair_2010.yaml").read_text())
    seed_runs.apply_set(doc, "studies.heading_correction.sensors.fleets.penair.heading.poor_hard_iron_sigma_nT=620")
    seed_runs.apply_set(doc, "periods.fit.every_days=5")
    seed_runs.apply_set(doc, "studies.heading_correction.sensors.fleets.penair.references.0.sigma_scale=1.1")
    doc["seed"] = 7
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    edited = load_campaign(tmp_path / "c.yaml").model_dump()
    orig = load_campaign(ROOT / "campaigns/penair_2010.yaml").model_dump()
    heading = edited["studies"]["heading_correction"]["sensors"]["fleets"]["penair"]
    assert heading["heading"]["poor_hard_iron_sigma_nT"] == 620
    assert heading["references"][0]["sigma_scale"] == pytest.approx(1.1)
    assert [p["every_days"] for p in edited["periods"] if p["name"] == "fit"] == [5]
    assert edited["seed"] == 7
    # nothing else moved
    for key in ("fleets", "sizes", "name"):
        assert edited[key] == orig[key]


def test_a_misspelt_path_is_an_error_naming_it():
    doc = yaml.safe_load((ROOT / "campaigns/penair_2010.yaml").read_text())
    with pytest.raises(SystemExit, match="poor_hard_iorn"):
        seed_runs.apply_set(doc, "studies.heading_correction.sensors.fleets.penair.heading.poor_hard_iorn=3")
    with pytest.raises(SystemExit, match="PATH=VALUE"):
        seed_runs.apply_set(doc, "seed")


def test_the_truth_cap_reaches_the_campaign_and_keeps_the_stores_path(tmp_path):
    doc = yaml.safe_load((ROOT / "campaigns/penair_2010.yaml").read_text())
    seed_runs.with_truth_cap(doc, 40)
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    assert load_campaign(tmp_path / "c.yaml").truth_store.max_gb == 40
    doc["truth_store"] = {"path": "/x/truth", "max_gb": 5}
    seed_runs.with_truth_cap(doc, 60)
    assert doc["truth_store"] == {"path": "/x/truth", "max_gb": 60}
    seed_runs.with_truth_cap(doc, None)
    assert doc["truth_store"]["max_gb"] == 60
    with pytest.raises(SystemExit, match="truth-max-gb"):
        seed_runs.with_truth_cap(doc, 0)


def test_a_set_that_the_size_block_would_undo_is_an_error_naming_the_size_path():
    doc = yaml.safe_load((ROOT / "campaigns/penair_2010.yaml").read_text())
    # sizes.reduced restates the selection's counts and replaces the periods list
    with pytest.raises(SystemExit, match=r"sizes\.reduced\.studies\.heading_correction\.selection\.poor"):
        seed_runs.check_not_shadowed(doc, "studies.heading_correction.selection.poor=5", "reduced")
    with pytest.raises(SystemExit, match=r"sizes\.reduced\.periods"):
        seed_runs.check_not_shadowed(doc, "periods.fit.every_days=5", "reduced")
    # keys the size does not restate pass, as does any set at the full size or inside sizes
    seed_runs.check_not_shadowed(doc, "studies.heading_correction.selection.by=transverse", "reduced")
    seed_runs.check_not_shadowed(
        doc, "studies.heading_correction.sensors.fleets.penair.heading.poor_count=4", "reduced"
    )
    seed_runs.check_not_shadowed(doc, "periods.fit.every_days=5", "full")
    seed_runs.check_not_shadowed(doc, "sizes.reduced.periods.0.every_days=20", "reduced")
    # and what the check lets through does reach the reduced campaign
    seed_runs.apply_set(doc, "studies.heading_correction.selection.by=total")
    doc["seed"] = 1
    path = ROOT / "campaigns" / "penair_2010.yaml"
    text = yaml.safe_dump(doc, sort_keys=False)
    from aerotruth.sim.campaign_loader import parse_campaign

    c = parse_campaign(text, base_dir=path.parent, size="reduced")
    assert c.section("heading_correction").selection.by == "total"
