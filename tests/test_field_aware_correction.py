"""The magnetic-latitude-aware correction on reports from the independent generator whose
hard iron scales with 1/H at each position (H straight from ppigrf)."""

import numpy as np
import obs_generator as gen
import pytest

from aerotruth.analysis.wind.field_aware_correction import FieldAwareDeviationFit, compare_on

pytestmark = pytest.mark.slow  # every test here flies JSBSim or takes over 5 s

H0 = 17000.0


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(1)
    truths = [gen.AircraftTruth("N1", 1.0, 3.0, -2.0, h0_nT=H0), gen.AircraftTruth("N2", -1.0, -2.0, 2.5, h0_nT=H0)]
    # spokes 300-1200 km from Minneapolis: H from ~14,800 to ~22,700 nT
    fit = gen.generate(truths, rng, flights=60, spoke_km=(300.0, 1200.0))
    test = gen.generate(truths, rng, flights=40, t_start=1_250_294_400.0, spoke_km=(300.0, 1200.0))
    return truths, fit, test


def test_hard_iron_coefficients_are_recovered_at_the_median_field(data):
    truths, fit, _ = data
    f = FieldAwareDeviationFit().fit(fit)
    t = f.to_table().set_index("aircraft")
    assert 15000 < f.h0_ < 21000
    for a in truths:
        r = t.loc[a.aircraft]
        assert r["terms"] == "hard"  # over one region 1/H and Z/H are collinear: the vertical terms are not fitted
        # truth B sin z + C cos z at H0 (17,000 nT) is (H0 / h0_) times that at the fit's median field
        k = H0 / f.h0_
        assert abs(r["A_deg"] - a.A) < 3 * r["A_se_deg"] + 0.05
        assert abs(r["B_h_deg"] - a.B * k) < 3 * r["B_h_se_deg"] + 0.05
        assert abs(r["C_h_deg"] - a.C * k) < 3 * r["C_h_se_deg"] + 0.05


def test_field_aware_correction_beats_the_constant_table_out_of_sample(data):
    _, fit, test = data
    c = compare_on(fit, test).set_index("aircraft").loc["all"]
    assert c["constant_table_rms_kt"] < 0.5 * c["uncorrected_rms_kt"]
    assert c["field_aware_rms_kt"] < c["constant_table_rms_kt"]
