"""Null control of `aerotruth diagnose` on aerotruth's own approach logs: JSBSim approach
truth from the truth store -> the campaign's inspection sensors (WAAS with its 12-s cyclic
noise and bias jumps, the first INS of the campaign, radar altimeter, TVPS, DGPS, pilot
marks: aerotruth.sensors.inspection_log) -> diagnose against the model of those sensors
(analysis.diagnose_fits.FitsModel.from_campaign, what `aerotruth diagnose --model
CAMPAIGN` assumes).

The approaches (the first `--approaches` tasks of the campaign's fits study: its runways,
days, masses and weather) are flown once into the truth store; each dataset is another
sensor seed on them. Nothing is hidden, so every finding is false (<= 5 per 100 required).
The model is the campaign's first INS: another INS (`--ins`) of a worse grade than the
first draws `ins_bias` findings by design; the others are still false.

    python validation/diagnose_fits_sim_null.py [--datasets 100] [--approaches 12]
        [--campaign campaigns/fits_tactical.yaml] [--ins LABEL]

Prints `label: value` lines.
"""

from __future__ import annotations

import argparse
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pandas as pd

from aerotruth import seeds
from aerotruth.analysis.diagnose.fits import FitsModel, diagnose_log
from aerotruth.sensors.inspection_log import approach_logs
from aerotruth.sim.campaign_loader import load_campaign
from aerotruth.sim.studies.fits import FitsStudy, planned_approach
from aerotruth.truth.store import TruthStore

ROOT = Path(__file__).resolve().parents[1]


def _fly(planned):
    out = TruthStore().approach(planned)
    return out.track is not None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--datasets", type=int, default=100)
    ap.add_argument("--approaches", type=int, default=12)
    ap.add_argument("--campaign", default=str(ROOT / "campaigns" / "fits_tactical.yaml"))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--ins", default=None, help="the INS of the campaign's fits sensors by label (default: the first)")
    a = ap.parse_args()
    campaign = load_campaign(a.campaign)
    section = campaign.section("fits")
    tasks = FitsStudy().expand(campaign, section)
    step = max(1, len(tasks) // a.approaches)  # spread over runways and days
    planned = [planned_approach(t, section, campaign.seed) for t in tasks[::step][: a.approaches]]
    with ProcessPoolExecutor(a.workers) as ex:
        flown = list(ex.map(_fly, planned))
    store = TruthStore()
    tracks = [
        (f"{p.spec.airport}-{p.spec.runway}-{p.spec.start_utc:%Y%m%dT%H%M}", store.approach(p).track)
        for p, ok in zip(planned, flown, strict=False)
        if ok
    ]
    print(f"approaches: {len(tracks)} of {len(planned)} flown")
    model = FitsModel.from_campaign(campaign)
    labels = [i.label for i in section.sensors.ins]
    if a.ins is not None and a.ins not in labels:
        raise SystemExit(f"--ins: expected one of {labels}, got {a.ins!r}")
    ins = a.ins or labels[0]
    print(f"ins: {ins}")
    found, n_with = Counter(), 0
    for s in range(a.datasets):
        frames = []
        for label, track in tracks:
            logs = approach_logs(
                track,
                section.sensors,
                lambda *n, _l=label, _s=s: seeds.generator(seeds.named_sequence(80_000 + _s, "sensor", _l, *n)),
                label,
            )
            frames.append(logs.logs[ins].assign(approach=label))
        f, _ = diagnose_log("simulated", pd.concat(frames, ignore_index=True), model)
        n_with += bool(f)
        found.update(x.effect for x in f)
        print(f"# dataset {s}: findings {[x.effect for x in f]}", flush=True)
    print(f"null_datasets: {a.datasets}")
    print(f"null_findings: {sum(found.values())}")
    print(f"null_datasets_with_a_finding: {n_with}")
    for k, v in sorted(found.items()):
        print(f"null_finding_{k}: {v}")


if __name__ == "__main__":
    main()
