"""The fits study: JSBSim approaches from the truth store through the inspection sensors
and the WAAS-aided FITS inside a campaign.

Independent expectations: the drawn cyclic noise (the residual must stay under 0.1 m and
at the analytic floor of the white + Gauss-Markov noise, computed here by hand from the
triangle taps), the truth position (the FITS error must be at the RA/TVPS accuracy), the
pairing (every INS variant sees the same WAAS noise), and `aerotruth fits` on the
exported log (it must reproduce the study's estimate)."""

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from aerotruth.app.fits import fits_main
from aerotruth.sim.campaign import run_campaign
from aerotruth.sim.campaign_file import ConfigError
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.executors import ExecutorChoice
from aerotruth.truth.store import TruthStore

ROOT = Path(__file__).resolve().parents[1]


def campaign(ins: str, extra: str = "", waas: str = "{}") -> str:
    return f"""\
name: ft
seed: 5
periods:
  - {{name: d, dates: [2009-08-15]}}
studies:
  fits:
    runways: [{{airport: KDLH, runway: "27"}}, {{airport: KRST, runway: "31"}}]
    periods: [d]
    turbulence: false
    sensors:
      waas: {waas}
      ins: {ins}
{extra}"""


INS = "[{grade: tactical}, {grade: automotive}, {grade: tactical, name: late, time_tag_error_s: 0.5}]"


def _run(text, out):
    run_campaign(parse_campaign(text), ExecutorChoice("local", workers=2), out=out, progress=False, log=lambda m: None)
    metrics = json.loads((out / "metrics.json").read_text())["metrics"]
    rows = pd.concat([pd.read_parquet(p) for p in sorted((out / "tasks").glob("fits--*.parquet"))], ignore_index=True)
    return metrics, rows


def _floor(T=12, white=0.03, gm=0.05, tau=100.0):
    k = np.arange(-T, T + 1)
    h = (T - np.abs(k)) / T**2
    d = -h
    d[T] += 1.0
    g = np.convolve(d, d)
    j = np.arange(len(g))
    rho = math.exp(-1.0 / tau)
    return math.sqrt(white**2 * np.sum(g**2) + gm**2 * g @ (rho ** np.abs(j[:, None] - j[None, :])) @ g)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("fits") / "run"
    return out, *_run(campaign(INS, "    equivalence: [{a: tactical, b: automotive}, {a: tactical, b: late}]"), out)


@pytest.mark.slow
def test_cyclic_noise_residual_is_under_0_1_m_and_at_the_analytic_floor(run):
    _, m, rows = run
    floor = _floor()
    assert m["fits.noise_floor_rms_m"] == pytest.approx(floor, rel=1e-9)
    assert m["fits.approaches"] == 2 and m["fits.approaches_diverged"] == 0
    for v in ("tactical", "automotive"):
        for a in "xyz":
            assert m[f"fits.{v}.resid_share_lt_0p1.{a}"] >= 0.9
            assert m[f"fits.{v}.resid_rms_m.{a}"] == pytest.approx(floor, rel=0.2)
    # a half-second time tag leaves the aircraft's motion in WAAS - INS: well above the floor
    assert m["fits.late.resid_rms_m.z"] > 1.5 * floor or m["fits.late.resid_rms_m.x"] > 1.5 * floor


@pytest.mark.slow
def test_noise_against_dgps_is_the_waas_noise_by_hand_and_the_fits_leaves_the_dgps_own(run):
    """The flight test's measure (FITS paper section V). By hand from the drawn levels:
    the 12-s cycle of amplitude 0.5 m (1 +- 0.3 sin) has mean square 0.5^2 (1 + 0.3^2/2) / 2,
    with the Gauss-Markov 0.05 m (less what the per-segment line takes), white 0.03 m and
    the DGPS's white 0.10 m vertical / 0.05 m horizontal: WAAS - DGPS between
    sqrt(cycle^2 + 0.03^2 + 0.1^2) and sqrt(cycle^2 + 0.05^2 + 0.03^2 + 0.1^2). The FITS
    removes the cycle: FITS - DGPS at least the DGPS's own noise, at most the DGPS, white,
    Gauss-Markov and the residual floor together."""
    out, m, _ = run
    cycle2 = 0.5**2 * (1 + 0.3**2 / 2) / 2
    for ax, dgps in (("y", 0.05), ("z", 0.10)):
        waas = m[f"fits.tactical.dgps_noise_waas_m.{ax}"]
        assert (
            math.sqrt(cycle2 + 0.03**2 + dgps**2) * 0.97
            <= waas
            <= math.sqrt(cycle2 + 0.05**2 + 0.03**2 + dgps**2) * 1.03
        )
        fits = m[f"fits.tactical.dgps_noise_fits_m.{ax}"]
        assert dgps * 0.95 <= fits <= math.sqrt(dgps**2 + 0.03**2 + 0.05**2 + _floor() ** 2) * 1.05
        assert m[f"fits.tactical.dgps_noise_improvement.{ax}"] == pytest.approx(1 - fits / waas, abs=1e-6)
    # the report's table beside the paper carries the same number
    vs = pd.read_csv(out / "tables" / "fits.versus_paper.csv").set_index("claim")
    row = vs.loc["Fig. 16: vertical noise against DGPS improved (tactical, vertical free)"]
    assert row["aerotruth"].startswith(f"{m['fits.tactical.dgps_noise_improvement.z']:.1%}")


@pytest.mark.slow
def test_fits_error_is_at_the_ra_tvps_accuracy_and_meets_the_requirement(run):
    _, m, rows = run
    ep = rows[(rows["kind"] == "epoch") & (rows["ins"] == "tactical")]
    near = ep[(ep["distance_to_threshold_m"] >= 0) & (ep["distance_to_threshold_m"] <= 10 * 1852)]
    # errors: RA 0.30 m and TVPS 0.60 m 95 % per reading, averaged over the 3-s window
    assert np.sqrt(np.mean(near["vertical_m"] ** 2)) < 0.25
    assert np.sqrt(np.mean(near["cross_m"] ** 2)) < 0.4
    assert m["fits.tactical.share_meeting.vertical.minimum"] == 1.0
    assert m["fits.tactical.share_meeting.cross.minimum"] == 1.0


@pytest.mark.slow
def test_ins_variants_are_paired_on_the_same_truth_and_waas_noise(run):
    _, m, rows = run
    ep = rows[rows["kind"] == "epoch"]
    a = ep[ep["ins"] == "tactical"].reset_index(drop=True)
    b = ep[ep["ins"] == "automotive"].reset_index(drop=True)
    for c in ("time_s", "waas_err_x_m", "waas_err_y_m", "waas_err_z_m", "n_true_z_m", "y_true_m"):
        assert np.array_equal(a[c].to_numpy(), b[c].to_numpy()), c
    assert not np.allclose(a["n_hat_z_m"], b["n_hat_z_m"])  # but their INS differ
    # TOST reported per channel, both ways
    assert m["fits.tost.tactical_vs_automotive.all.equivalent"] in (0.0, 1.0)
    assert m["fits.tost.tactical_vs_late.vertical.equivalent"] == 0.0


@pytest.mark.slow
def test_exported_log_runs_through_aerotruth_fits_with_its_runway_sidecar(run, tmp_path, capsys):
    out, m, rows = run
    log_path = out / "data" / "fits.approach_log.parquet"
    log = pd.read_parquet(log_path)
    assert list(log.columns[:16]) == [
        "approach",
        "time_s",
        "waas_x_m",
        "waas_y_m",
        "waas_z_m",
        "ins_x_m",
        "ins_y_m",
        "ins_z_m",
        "dgps_x_m",
        "dgps_y_m",
        "dgps_z_m",
        "ra_m",
        "tvps_y_m",
        "event",
        "sv_change",
        "iono_update",
    ]
    assert set(log["event"]) == {"", "thr", "end"}
    side = json.loads((out / "data" / "fits.approach_log.runway.json").read_text())
    assert set(side["approaches"]) == set(log["approach"])
    assert fits_main(str(log_path), str(tmp_path / "o")) == 0
    assert "fits.approach_log.runway.json" in capsys.readouterr().out
    bias = pd.read_csv(tmp_path / "o" / "bias.csv")
    # the study's own FITS on the same log gave the same bias (its approach rows)
    appr = rows[rows["kind"] == "approach"]
    appr = appr.set_axis(appr["approach"] + "/" + appr["ins"])
    assert len(bias) == 2 * 3 * 1 or len(bias) == len(set(log["approach"]))
    for _, b in bias.iterrows():
        for a in "xyz":
            assert b[f"bias_{a}_m"] == pytest.approx(appr.loc[b["approach"], f"bias_hat_{a}_m"], abs=1e-6)
    errors = pd.read_csv(tmp_path / "o" / "errors.csv")
    geo = side["approaches"][errors["approach"].iloc[0]]
    first = errors[errors["approach"] == errors["approach"].iloc[0]]
    assert np.allclose(first["range_loc_m"], geo["loc_x_m"] - first["x_m"])


@pytest.mark.slow
def test_bias_error_compares_each_segment_between_flagged_jumps_like_with_like(run, tmp_path):
    """WAAS jumping ~every 2 min (the module's truth, sensors only): on each segment between
    the log's flagged epochs the FITS position error's mean is the truth's bias there minus
    the bias the FITS took off (the cyclic residual and the Gauss-Markov noise average to a
    few cm), computed here from the exported log's flags and the epoch rows' errors alone."""
    waas = "{jump_rate_per_h: 30}"
    m, rows = _run(campaign("[{grade: automotive}]", waas=waas), tmp_path / "jumps")
    log = pd.read_parquet(tmp_path / "jumps" / "data" / "fits.approach_log.parquet")
    ep = rows[rows["kind"] == "epoch"]
    means, n_jumps = [], 0
    for name, lg in log.groupby("approach", sort=False):
        w = lg[np.isfinite(lg["waas_x_m"])]
        flag = ((w["sv_change"] > 0) | (w["iono_update"] > 0)).to_numpy().copy()
        flag[0] = False  # nothing before the first epoch to refer it to
        n_jumps += int(flag.sum())
        seg = np.cumsum(flag)
        e = ep[ep["approach"] == name.split("/")[0]]
        assert np.allclose(e["time_s"].to_numpy(), w["time_s"].to_numpy())
        err = e[["along_m", "cross_m", "vertical_m"]].to_numpy()
        means += [err[seg == k].mean(axis=0) for k in np.unique(seg)]
    assert n_jumps >= 2  # segments other than the threshold's exist
    expected = np.sqrt(np.mean(np.square(means), axis=0))
    got = np.array([m[f"fits.automotive.bias_err_rms_m.{a}"] for a in "xyz"])
    assert np.all(np.abs(got - expected) <= 0.1), (got, expected)
    sg = rows[rows["kind"] == "segment"]
    assert len(sg) == len(means)
    assert np.allclose(sg[["bias_err_x_m", "bias_err_y_m", "bias_err_z_m"]].to_numpy(), -np.array(means), atol=0.1)


@pytest.mark.slow
def test_the_campaigns_negative_control_is_detected_at_its_size_with_the_margin_from_the_requirement(tmp_path):
    """campaigns/fits_automotive.yaml on its first day (8 approaches flown as the campaign
    flies them: turbulence, the turn onto final) with the INS of its pairs. The margin is a
    tenth of the requirement's floor on the 95 % error: 0.1 x 0.3048 m / 1.96 = 15.55 mm
    vertical, 0.1 x 0.6096 m / 1.96 = 31.1 mm horizontal, by hand. From these approaches'
    paired differences of the vertical residual RMS, the power of the TOST to refuse the
    control at the campaign's 200 approaches (normal approximation, by hand:
    Phi((|mean| - margin) / (sd / sqrt 200) - z_0.95)) must reach 0.8, and the claimed pair
    must differ by less than a fifth of the margin."""
    import yaml
    from scipy import stats

    from aerotruth.sim.studies.fits import _channel_rms

    data = yaml.safe_load((ROOT / "campaigns" / "fits_automotive.yaml").read_text())
    fits = data["studies"]["fits"]
    control = next(e for e in fits["equivalence"] if e.get("expect") == "different")
    claim = next(e for e in fits["equivalence"] if e.get("expect", "equivalent") == "equivalent")
    used = {control["a"], control["b"], claim["a"], claim["b"]}
    fits["sensors"]["ins"] = [i for i in fits["sensors"]["ins"] if (i.get("name") or i["grade"]) in used]
    fits["export_logs"] = 0
    data["periods"][0]["end"] = data["periods"][0]["start"]  # the first day
    data.pop("sizes")
    m, rows = _run(yaml.safe_dump(data), tmp_path / "c")
    key = f"fits.tost.{control['a']}_vs_{control['b']}"
    margin = 0.1 * 0.3048 / 1.959964
    assert m[f"{key}.vertical.margin_m"] == pytest.approx(margin, rel=1e-6)
    assert m[f"{key}.horizontal.margin_m"] == pytest.approx(0.1 * 0.6096 / 1.959964, rel=1e-6)
    appr = rows[rows["kind"] == "approach"]
    assert appr["approach"].nunique() == 8
    rms = _channel_rms(appr)["vertical"].set_axis(appr["approach"] + "/" + appr["ins"])

    def diff(a, b):
        return np.array([rms[f"{x}/{a}"] - rms[f"{x}/{b}"] for x in appr["approach"].unique()])

    d = diff(control["a"], control["b"])
    power = stats.norm.cdf((abs(d.mean()) - margin) / (d.std(ddof=1) / math.sqrt(200)) - stats.norm.ppf(0.95))
    assert power >= 0.8, (d.mean(), d.std(ddof=1), power)
    assert abs(diff(claim["a"], claim["b"]).mean()) < 0.2 * margin
    assert m[f"{key}.vertical.equivalent"] == 0.0 and m[f"{key}.expect_met"] == 1.0  # refused on 8 approaches


@pytest.mark.slow
def test_a_log_without_tvps_runs_with_no_tvps_fix_and_keeps_the_waas_cross_track_bias(run, tmp_path, capsys):
    """The exported log with every TVPS reading blanked: refused by default (one line naming
    tvps_y_m and the way out), accepted with --no-tvps-fix; its cross-track then carries
    the WAAS's own bias: the FITS's mean cross-track error against the truth on the
    threshold's segment equals the drawn WAAS bias there within the cyclic residual and
    the Gauss-Markov noise (a few cm), while the along-track and vertical fixes stand."""
    from aerotruth.app.cli import main

    out, m, rows = run
    log = pd.read_parquet(out / "data" / "fits.approach_log.parquet")
    log = log[log["approach"].str.endswith("/tactical")].copy()
    log["tvps_y_m"] = np.nan
    path = tmp_path / "no_tvps.parquet"
    log.to_parquet(path)
    (tmp_path / "no_tvps.runway.json").write_text((out / "data" / "fits.approach_log.runway.json").read_text())
    assert main(["fits", str(path), "--out", str(tmp_path / "refused")]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "tvps_y_m" in err[0] and "--no-tvps-fix" in err[0]
    assert main(["fits", str(path), "--out", str(tmp_path / "o"), "--no-tvps-fix"]) == 0
    bias = pd.read_csv(tmp_path / "o" / "bias.csv").set_index("approach")
    traj = pd.read_csv(tmp_path / "o" / "trajectory.csv")
    ep = rows[(rows["kind"] == "epoch") & (rows["ins"] == "tactical")]
    for name, b in bias.iterrows():
        assert b["bias_y_m"] == 0.0
        label = name.split("/")[0]
        e = ep[ep["approach"] == label].reset_index(drop=True)
        t = traj[traj["approach"] == name].reset_index(drop=True)
        near = (e["distance_to_threshold_m"].abs() < 1000).to_numpy()
        waas_bias_y = (e["waas_err_y_m"] - e["n_true_y_m"]).to_numpy()[near].mean()  # bias + slow noise
        fits_err_y = (t["y_m"] - e["y_true_m"]).to_numpy()[near].mean()
        assert fits_err_y == pytest.approx(waas_bias_y, abs=0.08)


@pytest.mark.slow
def test_changing_a_sensor_never_reflies(run, tmp_path):
    store = TruthStore()
    before = store.flown_count()
    _run(campaign("[{grade: automotive}]", waas="{cyclic_waveform: stepped}"), tmp_path / "again")
    assert store.flown_count() == before


def test_bad_sections_get_one_line_naming_the_field():
    with pytest.raises(ConfigError, match="equivalence.*'nav'"):
        parse_campaign(campaign("[{grade: tactical}]", "    equivalence: [{a: tactical, b: nav}]"))
    with pytest.raises(ConfigError, match=r"runways\[0\].*KDLH has no runway"):
        parse_campaign(campaign("[{grade: tactical}]").replace('runway: "27"', 'runway: "99"'))
    with pytest.raises(ConfigError, match="INS names must be unique"):
        parse_campaign(campaign("[{grade: tactical}, {grade: tactical}]"))
