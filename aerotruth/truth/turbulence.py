"""Turbulence with a climatology for the truth legs: patches along the flight path, each with
an intensity drawn from the probability-of-exceedance curves of MIL-F-8785C (1980), section
3.7.2 and Figure 7 (the same curves in MIL-HDBK-1797), which JSBSim carries as its
"milspec" severity table: severity k (1..7) is the curve exceeded with probability
POE_OF_SEVERITY[k - 1] (2e-1, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6), and JSBSim looks the
rms gust intensity up at the aircraft's altitude (e.g. the 1e-2 curve: 7.4 fps at
3,750 ft, 4.6 at 15,000, 0.4 at 35,000; the 2e-1 curve is zero above 7,500 ft).

A patch draws u ~ U(0, 1), its probability of exceedance, and takes the most severe curve
it exceeds: P(severity >= k) = POE_k, so light turbulence (1e-2 and worse) is met on 1 %
of the path, moderate (1e-3) on 0.1 %. Below the least curve (u > 0.2) the patch takes
that curve (severity 1): zero intensity above 7,500 ft, and it keeps JSBSim's low-altitude
model (below 1,000 ft AGL sigma_w = 0.1 x the wind at 20 ft, MIL-F-8785C 3.7.3) that
severity 0 would switch off. The wind at 20 ft is the truth atmosphere's at the patch's
start. Patch lengths are exponential with mean PATCH_MEAN_M (an assumption: clear-air
turbulence comes in patches of tens of km; no source with a distribution was at hand).
The severity of a leg's patches is what the leg's seed draws; JSBSim's own generator
(seeded from the same stream) makes the gusts.
"""

from __future__ import annotations

import numpy as np

from aerotruth.units import FT

POE_OF_SEVERITY = (2e-1, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6)  # JSBSim milspec rows 1..7 (MIL-F-8785C Fig. 7)
PATCH_MEAN_M = 20_000.0
TURB_TYPE_MILSPEC = 3  # FGWinds ttMilspec: Dryden forms of MIL-STD-1797A as in Yeager (1998)
W20_HEIGHT_M = 6.1  # 20 ft


def severity_of(u: float) -> int:
    """The most severe curve exceeded by a patch whose probability of exceedance is u (>= 1)."""
    k = 1
    for j, p in enumerate(POE_OF_SEVERITY, start=1):
        if u <= p:
            k = j
    return k


class TurbulencePatches:
    """Sets JSBSim's milspec turbulence patch by patch along a leg (module docstring)."""

    def __init__(self, fdm, rng: np.random.Generator):
        self.fdm, self.rng = fdm, rng
        self.next_m = 0.0
        self.patches: list[tuple[float, int]] = []  # (start along the path, m; severity)
        fdm["atmosphere/turb-type"] = TURB_TYPE_MILSPEC
        fdm["simulation/randomseed"] = int(rng.integers(0, 2**31 - 1))

    def due(self, path_m: float) -> bool:
        """Whether the current patch has been flown at `path_m` (m along the path)."""
        return path_m >= self.next_m

    def update(self, path_m: float, w20_mps: float) -> None:
        """Starts the next patch at `path_m` (when `due`), with the truth wind at 20 ft (m/s)."""
        k = severity_of(float(self.rng.random()))
        self.fdm["atmosphere/turbulence/milspec/severity"] = k
        self.fdm["atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps"] = w20_mps / FT  # ft/s
        self.patches.append((path_m, k))
        self.next_m = path_m + float(self.rng.exponential(PATCH_MEAN_M))


__all__ = ["POE_OF_SEVERITY", "PATCH_MEAN_M", "TurbulencePatches", "severity_of"]
