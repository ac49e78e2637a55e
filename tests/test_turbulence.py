"""Turbulence climatology of the truth legs (aerotruth.truth.turbulence): a patch's severity
is the MIL-F-8785C curve its probability of exceedance exceeds."""

from __future__ import annotations

import numpy as np
import pytest

from aerotruth.truth.turbulence import POE_OF_SEVERITY, PATCH_MEAN_M, TurbulencePatches, severity_of


@pytest.mark.parametrize("u,k", [(0.9, 1), (0.2, 1), (0.15, 1), (0.1, 2), (0.05, 2), (0.01, 3), (0.002, 3),
                                 (1e-3, 4), (2e-5, 5), (1e-5, 6), (1e-6, 7), (1e-9, 7)])
def test_severity_is_the_most_severe_curve_exceeded(u, k):
    assert severity_of(u) == k


class _Props(dict):
    pass


def test_patches_follow_the_probabilities_of_exceedance_and_their_mean_length():
    rng = np.random.default_rng(5)
    fdm = _Props()
    p = TurbulencePatches(fdm, rng)
    assert fdm["atmosphere/turb-type"] == 3
    n, path = 200_000, 0.0
    while len(p.patches) < n:
        p.update(path, 7.0)
        path = p.next_m
    sev = np.array([k for _, k in p.patches])
    for k in (2, 3, 4):  # P(severity >= k) = POE of curve k; binomial 4-sigma bounds
        q = POE_OF_SEVERITY[k - 1]
        assert abs(np.mean(sev >= k) - q) < 4 * np.sqrt(q * (1 - q) / n), k
    lengths = np.diff([a for a, _ in p.patches])
    assert np.mean(lengths) == pytest.approx(PATCH_MEAN_M, rel=0.02)
    assert fdm["atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps"] == pytest.approx(7.0 / 0.3048)
    assert fdm["atmosphere/turbulence/milspec/severity"] == sev[-1]
