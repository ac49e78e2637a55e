"""The FITS paper's barometric result (section V, Fig. 16): with the AFIS's navigation INS
coupled to a barometer, "the noise is still improved about 50 %" in the vertical, while
the cyclic noise is "effectively removed" in the horizontal. What sets that number?

The measure is the paper's: the noise of X - DGPS (X the raw WAAS, or the FITS output),
detrended per segment between flagged jumps, over the scored span; improvement = 1 -
noise(FITS - DGPS) / noise(WAAS - DGPS) (aerotruth.analysis.fits.scoring.dgps_noise). On
the approaches of a FITS campaign (default campaigns/fits_tactical.yaml at its `reduced`
size), paired (same truth, WAAS noise, DGPS), the vertical improvement is measured for

* the navigation INS free (no barometer) and barometer-coupled over a grid of loop time
  constants (`--taus`) and barometer white-noise levels (`--whites`);
* each of them against a DGPS reference of `--dgps-sigmas` vertical noise (the DGPS's own
  noise is in both differences and bounds the improvement a perfect filter could show:
  printed as `ceiling`).

Prints `label: value` lines (`dgps_<s>.<variant>.improvement.z`, the horizontal `.y` for
comparison, and per DGPS level the ceiling 1 - sqrt(floor^2 + s^2) / noise(WAAS - DGPS)).
Each DGPS level is a campaign run folder under RESULTS (resumable).

    python validation/fits_baro_noise.py RESULTS [--taus 5,10,20,30,60] [--whites 0.3,1.0] [--dgps-sigmas 0.1,0.03]
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import sys
from pathlib import Path

import yaml

from aerotruth.analysis.fits.filter import noise_floor_rms
from aerotruth.sensors.waas import WaasSpec
from aerotruth.sim.campaign import run_campaign
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.executors import ExecutorChoice

ROOT = Path(__file__).resolve().parents[1]


def variants(taus: list[float], whites: list[float]) -> list[dict]:
    out = [{"grade": "navigation", "name": "nav_free"}]
    for w in whites:
        for tau in taus:
            out.append(
                {
                    "grade": "navigation",
                    "name": f"nav_baro_tau{tau:g}_white{w:g}",
                    "vertical": "baro",
                    "baro_loop_time_constant_s": tau,
                    "baro_white_sigma_m": w,
                }
            )
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results")
    ap.add_argument("--campaign", default=str(ROOT / "campaigns" / "fits_tactical.yaml"))
    ap.add_argument("--size", default="reduced")
    ap.add_argument("--taus", default="5,10,20,30,60", help="baro-inertial loop time constants (s)")
    ap.add_argument("--whites", default="0.3,1.0", help="barometer white noise per reading (m)")
    ap.add_argument("--dgps-sigmas", default="0.1,0.03", help="DGPS vertical white noise (m)")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    taus = [float(x) for x in args.taus.split(",")]
    whites = [float(x) for x in args.whites.split(",")]
    path = Path(args.campaign)
    base = yaml.safe_load(path.read_text())
    w = WaasSpec()
    floor = noise_floor_rms(12, w.white_sigma_m, w.gm_sigma_m, w.gm_tau_s)
    for s in (float(x) for x in args.dgps_sigmas.split(",")):
        data = copy.deepcopy(base)
        fits = data["studies"]["fits"]
        fits["sensors"]["ins"] = variants(taus, whites)
        fits["sensors"].setdefault("dgps", {})["sigma_vertical_m"] = s
        fits["equivalence"] = []
        fits["export_logs"] = 0
        data["name"] = f"{data['name']}_baro_noise"
        camp = parse_campaign(yaml.safe_dump(data, sort_keys=False), base_dir=path.parent, size=args.size)
        out = Path(args.results) / f"dgps_{s:g}"
        run_campaign(camp, ExecutorChoice("local", workers=args.workers), out=out, progress=False, log=lambda m: None)
        m = json.loads((out / "metrics.json").read_text())["metrics"]
        label = f"dgps_{s:g}"
        waas_z = m["fits.nav_free.dgps_noise_waas_m.z"]
        print(f"{label}.approaches: {m['fits.approaches']}")
        print(f"{label}.noise_waas_minus_dgps_m.z: {waas_z:.4f}")
        print(f"{label}.ceiling.z: {1 - math.sqrt(floor**2 + s**2) / waas_z:.3f}")
        for v in fits["sensors"]["ins"]:
            name = v["name"]
            print(f"{label}.{name}.improvement.z: {m[f'fits.{name}.dgps_noise_improvement.z']:.3f}")
            print(f"{label}.{name}.removed_share.z: {m[f'fits.{name}.removed_share.z']:.3f}")
        print(f"{label}.nav_free.improvement.y: {m['fits.nav_free.dgps_noise_improvement.y']:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
