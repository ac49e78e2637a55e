"""`aerotruth diagnose` on approach logs: effects hidden in logs from the independent
generator (tests/approach_log_generator.py, not aerotruth's sensors) must be found, ranked
first, sized within 25 % and give a positive held-out gain; nothing hidden, nothing found."""

import json

import approach_log_generator as gen
import numpy as np
import pandas as pd
import pytest

from aerotruth.analysis.diagnose.fits import FitsModel, diagnose_log
from aerotruth.app.cli import main

CASES = [
    ({"period_s": 6.0}, "cyclic_period", {"period_s": 6.0}),
    ({"second_period_s": 7.0}, "second_cyclic_period", {"period_s": 7.0}),
    ({"dgps_offset": (0.0, 0.3, 0.3)}, "dgps_offset", {"offset_y_m": 0.3, "offset_z_m": 0.3}),
    ({"unflagged_jump": (150.0, np.full(3, 1.5 / np.sqrt(3)))}, "waas_jump", {"step_m": 1.5}),
    ({"ins_bias_scale": 3.0}, "ins_bias", {"bias_scale": 3.0}),
    # a barometer-coupled INS whose loop is twice as wide as the model's (tau 15 s, not 30)
    ({"baro_loop_tau_s": 15.0}, "baro_coupling", {"loop_tau_s": 15.0}),
    # the WAAS fixes stamped 150 ms late
    ({"waas_latency_s": 0.15}, "waas_latency", {"latency_s": 0.15}),
]
BARO_MODEL = FitsModel(vertical="baro", baro_loop_tau_s=30.0)


@pytest.mark.parametrize("hidden, effect, sizes", CASES, ids=[c[1] for c in CASES])
def test_a_hidden_effect_is_ranked_first_sized_within_25_percent_with_held_out_gain(hidden, effect, sizes):
    log, _ = gen.make_log(20, seed=31, jumps_per_s=0.0, **hidden)  # 20 approaches of ~6 min
    findings, _ = diagnose_log("log", log, BARO_MODEL if "baro_loop_tau_s" in hidden else FitsModel())
    assert findings and findings[0].effect == effect, [f.effect for f in findings]
    for k, v in sizes.items():
        assert findings[0].parameters[k]["value"] == pytest.approx(v, rel=0.25)
    g = findings[0].gain
    assert g["held_out_after"] < g["held_out_before"]


@pytest.mark.parametrize("scale", [-1.0, 1.1])
def test_a_tvps_of_the_other_sign_or_scale_is_named_not_taken_for_a_dgps_offset(scale):
    """Approaches crossing the threshold 3 m (sd) off the centreline; the TVPS reads
    scale x the cross-track position. Eq. 18 fixes the cross-track bias on that reading,
    so FITS - DGPS is off by (1 - 1/k) y on each approach: slope 2 across approaches for
    the opposite sign, 1 - 1/1.1 = 0.091 for a 10 % scale (hand-worked)."""
    log, _ = gen.make_log(12, seed=31, jumps_per_s=0.0, threshold_y_sd_m=3.0, tvps_scale=scale)
    findings, _ = diagnose_log("log", log, FitsModel())
    assert [f.effect for f in findings] == ["tvps_scale"], [f.effect for f in findings]
    f = findings[0]
    assert f.parameters["slope"]["value"] == pytest.approx(
        1.0 - 1.0 / scale, abs=4 * f.parameters["slope"]["se"] + 0.005
    )
    assert f.parameters["tvps_scale"]["value"] == pytest.approx(scale, rel=0.05)
    assert f.gain["held_out_after"] < 0.1 < f.gain["held_out_before"]  # m: back to the FITS's own noise
    assert ("opposite sign" in f.cause) == (scale < 0)


@pytest.mark.slow
def test_a_tvps_as_the_model_says_gives_no_finding_when_approaches_spread():
    n = sum(
        len(diagnose_log("log", gen.make_log(12, seed=s, jumps_per_s=0.0, threshold_y_sd_m=3.0)[0], FitsModel())[0])
        for s in range(120, 126)
    )
    assert n == 0


FRAMES = {  # INS columns as logged -> the signed permutation P with INS = P r (r the runway frame)
    "y of the other sign": (lambda g: g.assign(ins_y_m=-g["ins_y_m"]), [[1, 0, 0], [0, -1, 0], [0, 0, 1]]),
    "z down": (lambda g: g.assign(ins_z_m=-g["ins_z_m"]), [[1, 0, 0], [0, 1, 0], [0, 0, -1]]),
    "x and y swapped": (
        lambda g: g.assign(ins_x_m=g["ins_y_m"], ins_y_m=g["ins_x_m"]),
        [[0, 1, 0], [1, 0, 0], [0, 0, 1]],
    ),
}


@pytest.mark.parametrize("frame", list(FRAMES))
@pytest.mark.parametrize("with_dgps", [True, False])
def test_an_ins_logged_in_another_frame_is_named_with_or_without_dgps(frame, with_dgps):
    """The generator's approaches wander 15 m laterally and 3 m vertically far out and level
    off over the runway: motion no cubic drift follows. An INS column of the other sign or
    two columns swapped is told from drift by that motion, even where the logged axis
    itself hardly moves beyond a cubic (x, at constant speed: the swap shows in y)."""
    mutate, p = FRAMES[frame]
    log, _ = gen.make_log(12, seed=35, jumps_per_s=1 / 120.0, jump_sigma=1.0)
    log = mutate(log)
    if not with_dgps:
        log = log.drop(columns=["dgps_x_m", "dgps_y_m", "dgps_z_m"])
    findings, _ = diagnose_log("log", log, FitsModel())
    assert [f.effect for f in findings] == ["ins_frame"], [f.effect for f in findings]
    f = findings[0]
    q, tested = np.asarray(f.evidence["frame"]), ["xyz".index(a) for a in f.evidence["axes_tested"]]
    assert tested == [1, 2]  # x hardly moves beyond a cubic at the generator's constant speed
    assert np.allclose(q[:, tested], np.asarray(p)[:, tested], atol=0.02), q
    assert f.gain["held_out_after"] < 0.1 * f.gain["held_out_before"]


@pytest.mark.parametrize("deg", [16.0, -40.0])
def test_ins_axes_turned_about_the_vertical_are_named_with_the_angle(deg):
    """An INS logged in axes turned by the declination (a magnetic course used for the true
    one: 16 deg) or by 40 deg: x along the course leaks into y by sin(angle)."""
    log, _ = gen.make_log(12, seed=35, jumps_per_s=0.0)
    th = np.radians(deg)
    x, y = log["ins_x_m"], log["ins_y_m"]
    log = log.assign(ins_x_m=np.cos(th) * x - np.sin(th) * y, ins_y_m=np.sin(th) * x + np.cos(th) * y)
    findings, _ = diagnose_log("log", log, FitsModel())
    assert [f.effect for f in findings] == ["ins_frame"], [f.effect for f in findings]
    q = np.asarray(findings[0].evidence["frame"])
    assert np.degrees(np.arctan2(-q[0, 1], q[1, 1])) == pytest.approx(deg, abs=1.0)  # from the tested y column
    assert "turned by " + ("+" if deg > 0 else "-") in findings[0].cause
    g = findings[0].gain
    assert g["held_out_after"] < 0.5 * g["held_out_before"]


def test_the_fits_command_refuses_an_ins_in_another_frame_naming_the_columns(tmp_path, capsys):
    log, _ = gen.make_log(4, seed=36, jumps_per_s=0.0)
    log.to_csv(tmp_path / "ok.csv", index=False)
    assert main(["fits", str(tmp_path / "ok.csv"), "--out", str(tmp_path / "ok")]) == 0
    log.assign(ins_z_m=-log["ins_z_m"]).to_csv(tmp_path / "z.csv", index=False)
    assert main(["fits", str(tmp_path / "z.csv"), "--out", str(tmp_path / "z")]) == 2
    err = capsys.readouterr().err
    assert "z.csv: columns ins_x_m/ins_y_m/ins_z_m: ins_z_m has the opposite sign" in err and err.count("\n") == 1


@pytest.mark.slow
def test_nothing_hidden_nothing_found():
    n = sum(
        len(diagnose_log("log", gen.make_log(12, seed=s, jumps_per_s=0.0)[0], FitsModel())[0]) for s in range(100, 110)
    )
    assert n == 0


@pytest.mark.slow
def test_a_baro_coupled_ins_as_the_model_says_gives_no_finding():
    for seed in (40, 41, 42):
        log, _ = gen.make_log(20, seed=seed, jumps_per_s=0.0, baro_loop_tau_s=30.0)
        assert diagnose_log("log", log, BARO_MODEL)[0] == []


def test_without_dgps_only_the_cyclic_period_and_the_ins_frame_are_tested():
    log, _ = gen.make_log(10, seed=32, jumps_per_s=0.0, period_s=6.0, dgps_offset=(0.0, 0.3, 0.3))
    findings, base = diagnose_log("log", log.drop(columns=["dgps_x_m", "dgps_y_m", "dgps_z_m"]), FitsModel())
    assert base["dgps"] is False and [f.effect for f in findings] == ["cyclic_period"]


def test_cli_writes_the_diagnosis_of_an_approach_log(tmp_path, capsys):
    log, _ = gen.make_log(12, seed=33, jumps_per_s=0.0, ins_bias_scale=3.0)
    path = tmp_path / "log.csv"
    log.to_csv(path, index=False)
    assert main(["diagnose", str(path), "--model", "campaigns/fits_tactical.yaml", "--out", str(tmp_path / "d")]) == 0
    doc = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    assert doc["kind"] == "approach_log" and doc["findings"][0]["effect"] == "ins_bias"
    assert (tmp_path / "d" / "figures" / "waas_periodogram.png").exists()
    assert "ins_bias" in capsys.readouterr().out


def test_the_logs_lever_arms_are_used():
    """The radar altimeter 2.4 m below the GNSS antenna, said per row in the log (as
    aerotruth's own logs do), WAAS jumps every 2 min, all flagged: nothing to find.
    Without the lever-arm column the same log reads as a 2.4-m DGPS offset (diagnose
    ignored the column and found exactly that on aerotruth's own logs). The scan for
    unflagged jumps skipping windows that hold a flagged one is checked by
    validation/diagnose_fits_sim_null.py (this generator puts the strongest step on the
    flagged epoch, which was always skipped)."""
    log, _ = gen.make_log(20, seed=33, jumps_per_s=1 / 120.0, jump_sigma=1.0, lever_arm_m=2.4)
    log = log.assign(ra_lever_arm_m=2.4)
    findings, _ = diagnose_log("log", log, FitsModel())
    assert findings == [], [(f.effect, f.parameters) for f in findings]
    no_arm, _ = diagnose_log("log", log.drop(columns=["ra_lever_arm_m"]), FitsModel())
    assert no_arm and no_arm[0].effect == "dgps_offset"
    assert no_arm[0].parameters["offset_z_m"]["value"] == pytest.approx(2.4, abs=0.1)


def test_an_approach_too_short_for_the_filter_is_one_line_naming_it(tmp_path, capsys):
    log, _ = gen.make_log(2, seed=34, jumps_per_s=0.0)
    a = log["approach"] == log["approach"].iloc[-1]
    t_thr = log.loc[a & (log["event"] == "thr"), "time_s"].iloc[0]
    log = log[~a | (log["time_s"] - t_thr).abs().lt(12.0)]  # ~24 WAAS epochs: the filter needs 4T = 48
    log.to_csv(tmp_path / "log.csv", index=False)
    assert (
        main(["diagnose", str(tmp_path / "log.csv"), "--model", "campaigns/quick.yaml", "--out", str(tmp_path / "d")])
        == 2
    )
    err = capsys.readouterr().err
    assert "log.csv: approach" in err and "expected at least 4T = 48" in err and err.count("\n") == 1


@pytest.mark.slow
def test_a_waas_latency_is_named_alone_and_the_fits_compensates_it(tmp_path):
    # uncompensated, a 0.2-s latency reads as a step of the WAAS bias in every approach's
    # level-off and a vertical DGPS offset; named, the other effects run on re-tagged epochs
    log, _ = gen.make_log(8, seed=34, jumps_per_s=0.0, waas_latency_s=0.2)
    findings, _ = diagnose_log("log", log, FitsModel())
    assert [f.effect for f in findings] == ["waas_latency"], [f.effect for f in findings]
    tau = findings[0].parameters["latency_s"]
    assert abs(tau["value"] - 0.2) < 4 * tau["se"] + 0.02
    ref, _ = gen.make_log(8, seed=34, jumps_per_s=0.0)  # the same flights and errors, no latency
    log.to_csv(tmp_path / "late.csv", index=False)
    ref.to_csv(tmp_path / "ref.csv", index=False)

    def vertical_rms(name, *opts):
        assert main(["fits", str(tmp_path / f"{name}.csv"), "--out", str(tmp_path / f"{name}{len(opts)}"), *opts]) == 0
        e = pd.read_csv(tmp_path / f"{name}{len(opts)}" / "errors.csv")
        return float(np.sqrt(np.mean(e["vertical_m"] ** 2)))

    late, fixed, truth = (
        vertical_rms("late"),
        vertical_rms("late", "--waas-latency", f"{tau['value']:.3f}"),
        vertical_rms("ref"),
    )
    assert late > 2.5 * truth and fixed < 1.15 * truth, (late, fixed, truth)


def test_an_unflagged_step_common_to_every_approach_is_named_alone():
    """A 1.5-m WAAS step 150 s into each of 12 approaches (0.87 m on each axis, ~150 s before
    the threshold): before it each approach's FITS is 1.5 m off the same way, which the
    latency and offset tests, run before the step scan, read as a DGPS station offset and a
    latency unless the steps are flagged first (validation/diagnose_fits_confusion_plan.md)."""
    log, _ = gen.make_log(
        12, seed=37, jumps_per_s=0.0, threshold_y_sd_m=3.0, unflagged_jump=(150.0, np.full(3, 1.5 / np.sqrt(3)))
    )
    findings, _ = diagnose_log("log", log, FitsModel())
    assert {f.effect for f in findings} == {"waas_jump"}, [f.effect for f in findings]
    assert len(findings) >= 10 and all(f.parameters["step_m"]["value"] == pytest.approx(1.5, rel=0.2) for f in findings)
