"""Power of the FITS campaign's negative control: does the equivalence test of section VI
tell an INS fault the requirement cares about from a good INS, at the campaign's size?

The campaign (default campaigns/fits_automotive.yaml) names its pairs under
`fits.equivalence`: claims (`expect: equivalent`, e.g. tactical against automotive) and
negative controls (`expect: different`, e.g. the automotive INS with its output stamped
late). The margin of each channel is derived from the requirement
(aerotruth.analysis.fits.scoring.requirement_margins: the share of the 1 ft / 2 ft floor
the FITS error's 95 % bound may move by), not from the effect seen.

A pilot of the campaign (its first `--days` days; every runway) is run with the campaign's
INS and, beside them, the control's INS at each time-tag error of `--tags` (paired: same
truth, WAAS noise, RA, TVPS; only the INS output's time tag differs). From the pilot's
per-approach paired differences d_i = RMS_i(a) - RMS_i(b) of the cyclic-noise residual
(all, horizontal, vertical channels), the test at the campaign's full size N is drawn by
resampling N approaches with replacement (`--boot` times): a control is detected when
the TOST does not call the pair equivalent in at least one channel; a claim holds when it
calls it equivalent in every channel.

Prints `label: value` lines: the margins, the campaign's size, per pair the mean
differences and `power` (controls) or `equivalence_power` (claims), `power:` for the
campaign's own control, and `min_detectable_timetag_s:` (the smallest time-tag error of
the grid detected with power >= 0.8). The pilot run is a campaign run folder: it resumes.

    python validation/fits_control_power.py RESULTS [--days 4] [--tags 0.02,0.05,0.06,0.07,0.08,0.09,0.1,0.15,0.2,0.3]
"""

from __future__ import annotations

import argparse
import copy
import datetime as dt
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from aerotruth.analysis.fits.scoring import tost_paired
from aerotruth.sim.campaign import run_campaign
from aerotruth.sim.campaign_loader import load_campaign, parse_campaign
from aerotruth.sim.executors import ExecutorChoice
from aerotruth.sim.studies.fits import _channel_rms

ROOT = Path(__file__).resolve().parents[1]
CHANNELS = ("all", "horizontal", "vertical")
POWER_TARGET = 0.8


def _tag_label(ins: dict, tag: float) -> str:
    return f"{ins.get('name') or ins['grade']}_tag{round(tag * 1000):d}ms"


def pilot_campaign(data: dict, days: int, tags: list[float]) -> tuple[dict, dict[float, str]]:
    """The campaign's first `days` days, with the control's INS added at every time tag."""
    data = copy.deepcopy(data)
    fits = data["studies"]["fits"]
    for p in data["periods"]:
        if "start" not in p:
            raise SystemExit(f"periods: expected start/end periods, got {p}")
        start = dt.date.fromisoformat(str(p["start"]))
        end = dt.date.fromisoformat(str(p["end"]))
        p["end"] = min(end, start + dt.timedelta(days=days - 1)).isoformat()
    data.pop("sizes", None)
    data["name"] = f"{data['name']}_control_power"
    controls = [e for e in fits.get("equivalence", []) if e.get("expect") == "different"]
    if not controls:
        raise SystemExit("fits.equivalence: expected a negative control (a pair with `expect: different`)")
    by_label = {(i.get("name") or i["grade"]): i for i in fits["sensors"]["ins"]}
    base = dict(by_label[controls[0]["b"]])
    base.pop("name", None)
    base.pop("time_tag_error_s", None)
    labels = {}
    for tag in tags:
        label = _tag_label(base, tag)
        if label not in by_label:
            fits["sensors"]["ins"].append({**base, "name": label, "time_tag_error_s": tag})
        labels[tag] = label
    fits["export_logs"] = 0
    return data, labels


def paired_differences(rows: pd.DataFrame, a: str, b: str) -> pd.DataFrame:
    """Per approach (index) and channel (columns): RMS(a) - RMS(b) of the residual."""
    appr = rows[(rows["kind"] == "approach") & ~rows["diverged"].astype(bool)]
    ch = _channel_rms(appr)
    out = {}
    for c in CHANNELS:
        s = ch[c].set_axis(appr["approach"] + "|" + appr["ins"])
        pa = s[s.index.str.endswith("|" + a)].rename(lambda k: k.rsplit("|", 1)[0])
        pb = s[s.index.str.endswith("|" + b)].rename(lambda k: k.rsplit("|", 1)[0])
        common = pa.index.intersection(pb.index)
        out[c] = pa.loc[common] - pb.loc[common]
    return pd.DataFrame(out)


def resampled_verdicts(d: pd.DataFrame, margins: dict, n: int, boot: int, rng: np.random.Generator) -> np.ndarray:
    """(boot, channels) bool: the TOST's `equivalent` on `boot` campaigns of n approaches
    drawn with replacement from the pilot's differences."""
    x = d[list(CHANNELS)].to_numpy(float)
    out = np.zeros((boot, len(CHANNELS)), bool)
    for b in range(boot):
        idx = rng.integers(0, len(x), n)
        for j, c in enumerate(CHANNELS):
            out[b, j] = tost_paired(x[idx, j], np.zeros(n), margins[c])["equivalent"]
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", help="run folder of the pilot (resumable)")
    ap.add_argument("--campaign", default=str(ROOT / "campaigns" / "fits_automotive.yaml"))
    ap.add_argument("--days", type=int, default=4, help="the pilot: the campaign's first days (every runway)")
    ap.add_argument(
        "--tags",
        default="0.02,0.05,0.06,0.07,0.08,0.09,0.1,0.15,0.2,0.3",
        help="time-tag errors of the control's INS (s)",
    )
    ap.add_argument("--boot", type=int, default=2000, help="resampled campaigns per pair")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    tags = sorted(float(t) for t in args.tags.split(","))
    path = Path(args.campaign)
    data = yaml.safe_load(path.read_text())
    full = load_campaign(path)
    n_campaign = len(full.days(full.studies["fits"].periods)) * len(full.studies["fits"].runways)
    n_campaign *= full.studies["fits"].approaches_per_day
    pilot, labels = pilot_campaign(data, args.days, tags)
    camp = parse_campaign(yaml.safe_dump(pilot, sort_keys=False), base_dir=path.parent)
    out = Path(args.results)
    run_campaign(camp, ExecutorChoice("local", workers=args.workers), out=out, progress=False, log=lambda m: None)
    rows = pd.concat([pd.read_parquet(p) for p in sorted((out / "tasks").glob("fits--*.parquet"))], ignore_index=True)

    section = camp.studies["fits"]
    rng = np.random.default_rng(args.seed)
    n_pilot = int(rows.loc[rows["kind"] == "approach", "approach"].nunique())
    print(f"campaign: {path.name}")
    print(f"campaign_approaches: {n_campaign}")
    print(f"pilot_approaches: {n_pilot}")
    control = next(e for e in section.equivalence if e.expect == "different")
    margins = control.margins()
    for c in CHANNELS:
        print(f"margin_m.{c}: {margins[c]:.4f}")
    power_of: dict[str, float] = {}
    for e in section.equivalence:
        d = paired_differences(rows, e.a, e.b)
        v = resampled_verdicts(d, e.margins(), n_campaign, args.boot, rng)
        key = f"{e.a}_vs_{e.b}"
        for c in CHANNELS:
            print(f"{key}.mean_diff_m.{c}: {d[c].mean():.4f}")
        if e.expect == "equivalent":
            print(f"{key}.equivalence_power: {np.mean(v.all(axis=1)):.3f}")
        else:
            power_of[e.b] = float(np.mean(~v.all(axis=1)))
            print(f"{key}.power: {power_of[e.b]:.3f}")
    detectable = []
    for tag in tags:
        d = paired_differences(rows, control.a, labels[tag])
        v = resampled_verdicts(d, margins, n_campaign, args.boot, rng)
        p = float(np.mean(~v.all(axis=1)))
        for c in CHANNELS:
            print(f"timetag_{tag:g}s.mean_diff_m.{c}: {d[c].mean():.4f}")
        print(f"timetag_{tag:g}s.power: {p:.3f}")
        if p >= POWER_TARGET:
            detectable.append(tag)
    print(f"power: {power_of[control.b]:.3f}")
    print(f"min_detectable_timetag_s: {min(detectable) if detectable else float('nan'):g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
