"""Runway-relative sensors and DGPS against their stated error models."""

import numpy as np
import pytest

from aerotruth.sensors.dgps import DgpsSpec
from aerotruth.sensors.ranging import EventButtonSpec, RadarAltimeterSpec, TvpsSpec, event_flags

L = 2500.0


def pass_track(n=20001):
    x = np.linspace(-3000.0, 3000.0, n)
    return np.column_stack([x, np.full(n, 2.0), np.where(x < 0, 15.0 - x * np.tan(np.radians(3)), 15.0)])


def test_radar_altimeter_reads_height_over_the_runway_only_with_0_30_m_95_percent():
    xyz = pass_track()
    ra = RadarAltimeterSpec().draw(np.random.default_rng(0)).apply(xyz, L, np.random.default_rng(1))
    over = (xyz[:, 0] >= 0) & (xyz[:, 0] <= L)
    assert np.isnan(ra[~over]).all() and np.isfinite(ra[over]).all()
    err = ra[over] - xyz[over, 2]
    assert np.percentile(np.abs(err), 95) == pytest.approx(0.30, rel=0.05)


def test_tvps_sees_the_runway_from_its_view_distance_with_0_60_m_95_percent():
    xyz = pass_track()
    tv = TvpsSpec(view_from_m=600.0).draw(np.random.default_rng(0)).apply(xyz, L, np.random.default_rng(2))
    seen = (xyz[:, 0] >= -600.0) & (xyz[:, 0] <= L)
    assert np.isnan(tv[~seen]).all()
    assert np.percentile(np.abs(tv[seen] - 2.0), 95) == pytest.approx(0.60, rel=0.05)


def test_event_mark_follows_the_crossing_by_the_reaction_time():
    t = np.arange(0.0, 100.0, 0.125)  # the paper's 8 Hz grid
    x = (t - 40.03) * 70.0  # crosses the threshold at t = 40.03 s
    flags = event_flags(t, x, EventButtonSpec(reaction_mean_s=0.2, reaction_sd_s=0.0), np.random.default_rng(0))
    assert flags.sum() == 1 and t[flags == 1][0] == pytest.approx(40.25)  # first sample after 40.23 s


def test_dgps_noise_and_survey_offset():
    spec = DgpsSpec(survey_offset_m=(0.0, 0.3, 0.0))
    d = spec.draw(np.random.default_rng(0))
    xyz = np.zeros((100_000, 3))
    got = d.apply(xyz, np.random.default_rng(3))
    assert got.mean(axis=0) == pytest.approx([0.0, 0.3, 0.0], abs=0.002)
    assert got.std(axis=0) == pytest.approx([0.05, 0.05, 0.10], rel=0.02)
    assert list(d.sample_times(0.1, 1.0)) == [0.2, 0.4, 0.6, 0.8, 1.0]


def test_negative_sigma_is_refused_naming_the_field():
    with pytest.raises(ValueError, match="sigma_m"):
        RadarAltimeterSpec(sigma_m=-0.1)
