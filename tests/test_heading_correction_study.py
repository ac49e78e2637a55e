"""The heading_correction study's own logic: the control-group adjustment against the
wind paper's Table II, the selection of poor and control aircraft by before-period RMS
(computed here by hand) on reports from the independent generator, what gets uploaded,
and periods subsampled by every_days."""

import numpy as np
import obs_generator as gen
import pandas as pd
import pytest

from aerotruth.analysis.wind.paper_draw import derived_cells
from aerotruth.sensors.tamdar import LookupTableCorrection, OffsetCorrection
from aerotruth.sim.campaign_file import ConfigError
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.studies.heading_correction import STUDY, HeadingCorrectionConfig, uploaded_correction


def test_control_adjustment_reproduces_the_papers_table_ii_rows():
    # wind paper Table II: the measured cells; the adjusted and improvement rows follow by subtraction
    cells = pd.DataFrame(
        [
            {
                "group": "poor",
                "period": "before",
                "n": 165846,
                "rms_kt": 10.8,
                "longitudinal_rms_kt": 5.4,
                "transverse_rms_kt": 9.8,
            },
            {
                "group": "poor",
                "period": "after",
                "n": 142971,
                "rms_kt": 9.0,
                "longitudinal_rms_kt": 5.5,
                "transverse_rms_kt": 6.8,
            },
            {
                "group": "control",
                "period": "before",
                "n": 143248,
                "rms_kt": 8.8,
                "longitudinal_rms_kt": 5.4,
                "transverse_rms_kt": 7.1,
            },
            {
                "group": "control",
                "period": "after",
                "n": 132887,
                "rms_kt": 9.4,
                "longitudinal_rms_kt": 5.8,
                "transverse_rms_kt": 7.6,
            },
        ]
    )
    t = derived_cells(cells).set_index(["group", "period"])
    cols = ["rms_kt", "longitudinal_rms_kt", "transverse_rms_kt"]
    assert t.loc[("poor", "after_adjusted"), cols].tolist() == pytest.approx([8.4, 5.1, 6.3])
    assert t.loc[("poor", "improvement"), cols].tolist() == pytest.approx([2.4, 0.3, 3.5])
    assert t.loc[("control", "change"), cols].tolist() == pytest.approx([0.6, 0.4, 0.5])
    # with the paired twin (the poor group's after reports without tables) the table's own effect
    twin = {
        "group": "poor",
        "period": "after_untreated",
        "n": 142971,
        "rms_kt": 11.0,
        "longitudinal_rms_kt": 5.6,
        "transverse_rms_kt": 9.9,
    }
    t = derived_cells(pd.concat([cells, pd.DataFrame([twin])], ignore_index=True)).set_index(["group", "period"])
    assert t.loc[("poor", "table_effect"), cols].tolist() == pytest.approx([2.0, 0.1, 3.1])
    assert t.loc[("poor", "improvement"), cols].tolist() == pytest.approx([2.4, 0.3, 3.5])


def _section(poor=2, control=1, **kw):
    return HeadingCorrectionConfig(
        fleets=["f"],
        periods={"fit": "a", "before": "b", "after": "c"},
        selection={"poor": poor, "control": control},
        **kw,
    )


def test_fit_selects_by_before_rms_and_learns_each_aircrafts_table():
    rng = np.random.default_rng(5)
    truths = [
        gen.AircraftTruth("N1", 0.0, 0.3, 0.0),
        gen.AircraftTruth("N2", 2.0, 3.0, -2.0),
        gen.AircraftTruth("N3", -1.0, 0.5, 0.5),
        gen.AircraftTruth("N4", 3.0, -2.5, 2.0),
    ]
    fit = gen.generate(truths, rng, flights=30)
    before = gen.generate(truths, rng, flights=10, t_start=1_250_294_400.0)
    common = {"fleet": "f", "heading_input": "magnetic", "heading_class": "x", "trigger": "pressure"}
    rows = pd.concat([fit.assign(stage="fit", **common), before.assign(stage="before", **common)], ignore_index=True)
    rows.insert(0, "task_id", "t")
    table = STUDY.fit("corrections", rows, _section(), np.random.default_rng(0))

    # before RMS by hand: vector (report - reference), unbanked reports, every (report, model) pair
    b = before[before["roll_deg"].abs() <= 10]
    u = lambda s, d: -s * np.sin(np.radians(d))  # noqa: E731
    v = lambda s, d: -s * np.cos(np.radians(d))  # noqa: E731
    e2 = (u(b.wind_speed_kt, b.wind_dir_deg) - u(b.ref_wind_speed_kt, b.ref_wind_dir_deg)) ** 2 + (
        v(b.wind_speed_kt, b.wind_dir_deg) - v(b.ref_wind_speed_kt, b.ref_wind_dir_deg)
    ) ** 2
    by_hand = np.sqrt(e2.groupby(b["aircraft"]).mean()).sort_values()
    t = table.set_index("aircraft")
    assert t["before_rms_kt"].reindex(by_hand.index).to_numpy() == pytest.approx(by_hand.to_numpy(), rel=1e-9)
    assert set(t.index[t["group"] == "poor"]) == set(by_hand.index[-2:])
    assert list(t.index[t["group"] == "control"]) == [by_hand.index[0]]
    # the large deviations were learned: the table undoes eq. 2 at the nodes to within a few tenths
    for a in (truths[1], truths[3]):
        z = np.arange(0, 360, 45.0)
        lut = t.loc[a.aircraft, [f"lut_{int(h):03d}_deg" for h in z]].to_numpy(float)
        assert np.max(np.abs(lut + a.deviation(z))) < 0.6


def test_selection_by_transverse_ranks_the_heading_not_the_airspeed():
    # N2 reads TAS 6 % high (~17 kt along track at 280 kt) with a true heading system; N3 has a
    # 3-deg sinusoid (~15 kt across track). By total RMS N2 is the worst; by the transverse
    # component (the heading's share, wind paper section 6) N3 is, and N2 sits with N1 (clean).
    rng = np.random.default_rng(11)
    truths = [
        gen.AircraftTruth("N1", 0.0, 0.0, 0.0),
        gen.AircraftTruth("N2", 0.0, 0.0, 0.0, tas_scale=0.06),
        gen.AircraftTruth("N3", 0.0, 3.0, 0.0),
    ]
    fit = gen.generate(truths, rng, flights=20)
    before = gen.generate(truths, rng, flights=10, t_start=1_250_294_400.0)
    common = {"fleet": "f", "heading_input": "magnetic", "heading_class": "x", "trigger": "pressure"}
    rows = pd.concat([fit.assign(stage="fit", **common), before.assign(stage="before", **common)], ignore_index=True)
    rows.insert(0, "task_id", "t")
    by_total = STUDY.fit("corrections", rows, _section(poor=1, control=1), np.random.default_rng(0)).set_index(
        "aircraft"
    )
    assert by_total["before_rms_kt"].idxmax() == "N2"
    assert list(by_total.index[by_total["group"] == "poor"]) == ["N2"]
    section = _section(poor=1, control=1)
    section = section.model_copy(update={"selection": section.selection.model_copy(update={"by": "transverse"})})
    by_transverse = STUDY.fit("corrections", rows, section, np.random.default_rng(0)).set_index("aircraft")
    assert list(by_transverse.index[by_transverse["group"] == "poor"]) == ["N3"]
    assert (
        by_transverse.loc["N2", "before_transverse_rms_kt"] < 0.6 * by_transverse.loc["N3", "before_transverse_rms_kt"]
    )
    assert list(by_transverse.index[by_transverse["group"] == "control"]) != ["N3"]
    with pytest.raises(Exception, match="total|transverse"):
        HeadingCorrectionConfig(
            fleets=["f"],
            periods={"fit": "a", "before": "b", "after": "c"},
            selection={"poor": 1, "control": 1, "by": "longitudinal"},
        )


def test_what_is_uploaded():
    lut = {f"lut_{h:03d}_deg": float(h) / 100 for h in range(0, 360, 45)}
    table = pd.DataFrame(
        [
            {"aircraft": "P1", "group": "poor", "status": "fitted", "heading_input": "magnetic", **lut},
            {
                "aircraft": "P2",
                "group": "poor",
                "status": "offset_only",
                "heading_input": "true",
                **{k: -2.0 for k in lut},
            },
            {"aircraft": "P3", "group": "poor", "status": "refused", "heading_input": "magnetic", **lut},
            {"aircraft": "C1", "group": "control", "status": "fitted", "heading_input": "magnetic", **lut},
        ]
    )
    c = uploaded_correction(table, "P1")
    assert isinstance(c, LookupTableCorrection) and c.lut_deg == pytest.approx(list(lut.values()))
    c = uploaded_correction(table, "P2")
    assert isinstance(c, OffsetCorrection) and c.offset_deg == -2.0
    assert uploaded_correction(table, "P3") is None and uploaded_correction(table, "C1") is None
    assert uploaded_correction(table, "nobody") is None


PERIODS = """\
name: p
seed: 1
fleets:
  - {name: f, network: mesaba, aircraft: [N1, N2, N3]}
periods:
  - {name: a, start: 2009-07-01, end: 2009-07-09, every_days: 4}
  - {name: b, dates: [2009-08-15]}
  - {name: c, dates: [2009-10-25]}
studies:
  heading_correction:
    fleets: [f]
    periods: {fit: a, before: b, after: c}
    selection: {poor: 2, control: 1}
"""


def test_every_days_subsamples_a_period_and_the_selection_must_fit_the_fleet():
    c = parse_campaign(PERIODS)
    assert [d.isoformat() for d in c.period("a").days()] == ["2009-07-01", "2009-07-05", "2009-07-09"]
    with pytest.raises(ConfigError, match=r"studies\.heading_correction\.selection: poor \+ control = 4 exceeds the 3"):
        parse_campaign(PERIODS.replace("control: 1", "control: 2"))
    with pytest.raises(ConfigError, match=r"every_days subsamples start/end periods"):
        parse_campaign(PERIODS.replace("dates: [2009-08-15]}", "dates: [2009-08-15], every_days: 2}"))
    with pytest.raises(
        ConfigError, match=r"studies\.heading_correction\.periods\.after: expected the name of one of the periods"
    ):
        parse_campaign(PERIODS.replace("after: c}", "after: z}"))


def test_published_cells_sit_beside_the_simulated_ones_with_their_role():
    from aerotruth.sim.studies.heading_correction import PaperTable, versus_paper

    sim = pd.DataFrame(
        [{"group": "poor", "period": "before", "rms_kt": 11.0, "longitudinal_rms_kt": 5.0, "transverse_rms_kt": 9.0}]
    )
    paper = PaperTable(
        source="Table II",
        cells=[
            {"group": "poor", "period": "before", "rms_kt": 10.8, "longitudinal_rms_kt": 5.4, "role": "calibrated"},
            {"group": "poor", "period": "after", "rms_kt": 9.0, "role": "predicted"},
        ],
    )
    t = versus_paper(sim, paper)
    assert t[["component", "paper_kt", "role"]].values.tolist() == [
        ["total", 10.8, "calibrated"],
        ["longitudinal", 5.4, "calibrated"],
        ["total", 9.0, "predicted"],
    ]
    assert t["difference_kt"].iloc[:2].tolist() == pytest.approx([0.2, -0.4]) and np.isnan(t["simulated_kt"].iloc[2])


def test_rms_by_altitude_and_the_trustworthy_days_by_hand():
    """The figure tables (wind paper Figs. 5/6, 10, 11-14): a band's RMS is the root mean
    square of every (report, model) vector difference in it; the poor group's after rows are
    adjusted by the control's change of the whole table; an aircraft is trustworthy on a day
    when that day's RMS is under the threshold."""
    from aerotruth.sim.studies.heading_correction import ALTITUDE_BANDS_FT, rms_by_altitude, trustworthy_by_day

    rng = np.random.default_rng(8)
    truths = [gen.AircraftTruth("N1", 0.0, 0.3, 0.0), gen.AircraftTruth("N2", 2.0, 4.0, -2.0)]
    scored = {}
    for stage, t0 in (("before", 1_250_294_400.0), ("after", 1_256_000_000.0)):
        o = gen.generate(truths, rng, flights=12, t_start=t0)
        o["date"] = pd.to_datetime(o["time"], unit="s").dt.date.astype(str)
        o["group"] = np.where(o["aircraft"] == "N2", "poor", "control")
        scored[stage] = o
    table = pd.DataFrame(
        [{"group": "control", "period": "change", "rms_kt": 0.5, "longitudinal_rms_kt": 0.2, "transverse_rms_kt": 0.4}]
    )
    alt = rms_by_altitude(scored, table)

    def e(o):
        u = lambda s, d: -s * np.sin(np.radians(d))  # noqa: E731
        v = lambda s, d: -s * np.cos(np.radians(d))  # noqa: E731
        return np.hypot(
            u(o.wind_speed_kt, o.wind_dir_deg) - u(o.ref_wind_speed_kt, o.ref_wind_dir_deg),
            v(o.wind_speed_kt, o.wind_dir_deg) - v(o.ref_wind_speed_kt, o.ref_wind_dir_deg),
        )

    b = scored["before"]
    band = (b["group"] == "poor") & (b["pressure_altitude_ft"] >= 10000) & (b["pressure_altitude_ft"] < 15000)
    row = alt[
        (alt.group == "poor") & (alt.period == "before") & (alt.phase == "all") & (alt.altitude_band == "10000-15000")
    ]
    assert row["n"].iloc[0] == band.sum()
    assert row["rms_kt"].iloc[0] == pytest.approx(float(np.sqrt(np.mean(e(b[band]) ** 2))), rel=1e-9)
    after = alt[(alt.group == "poor") & (alt.period == "after")].set_index(["phase", "altitude_band"])
    adj = alt[(alt.group == "poor") & (alt.period == "after_adjusted")].set_index(["phase", "altitude_band"])
    assert (adj["rms_kt"] - after.loc[adj.index, "rms_kt"]).to_numpy() == pytest.approx(-0.5)
    assert (adj["transverse_rms_kt"] - after.loc[adj.index, "transverse_rms_kt"]).to_numpy() == pytest.approx(-0.4)
    assert set(alt["phase"]) >= {"all", "level"} and (alt["n"] >= 20).all()
    assert len(ALTITUDE_BANDS_FT) >= 2

    daily = trustworthy_by_day(scored, _section(trustworthy_rms_kt=6.0))
    for r in daily.itertuples():
        o = scored[r.period]
        day = o[o["date"] == r.date]
        rms = np.sqrt((e(day) ** 2).groupby(day["aircraft"]).mean())
        assert (r.trustworthy, r.untrustworthy) == (int((rms < 6.0).sum()), int((rms >= 6.0).sum()))
    assert daily["trustworthy"].sum() > 0 and daily["untrustworthy"].sum() > 0


def test_fit_figure_draws_the_fits_own_frame_and_gates(tmp_path):
    """The fit-period figure (wind paper Figs. 3/8) plots the heading errors the fit used:
    in its heading frame (magnetic here) and with its gates (the reports' position step,
    stored with the learned tables)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from aerotruth.analysis.wind.heading_errors import heading_errors
    from aerotruth.app.figures import FigureFolder
    from aerotruth.sim.studies import Summary

    rng = np.random.default_rng(8)
    truths = [gen.AircraftTruth("N1", 1.0, 3.0, -2.0), gen.AircraftTruth("N2", 0.0, 0.2, 0.1)]
    fit = gen.generate(truths, rng, flights=20)
    before = gen.generate(truths, rng, flights=6, t_start=1_250_294_400.0)
    common = {"fleet": "f", "heading_input": "magnetic", "heading_class": "x", "trigger": "pressure"}
    rows = pd.concat([fit.assign(stage="fit", **common), before.assign(stage="before", **common)], ignore_index=True)
    rows.insert(0, "task_id", "t")
    section = _section(poor=1, control=1, fit_heading="magnetic", sensors={"reports": {"lat_lon_step_deg": 0.02}})
    table = STUDY.fit("corrections", rows, section, np.random.default_rng(0))
    assert (table["gate_position_step_deg"] == 0.02).all() and (table["gate_max_roll_deg"] == 10.0).all()
    plt.close("all")
    figs = STUDY.figures(rows, Summary({}, {}), {"corrections": table}, FigureFolder(tmp_path))
    assert "heading_correction_fits" in [f.stem for f in figs]
    ax = plt.gcf().axes[0]
    poor = table.loc[table["group"] == "poor", "aircraft"].iloc[0]
    errs = heading_errors(fit[fit["aircraft"] == poor], section.gates())
    used = errs[errs["gate"] == "used"]
    assert "magnetic" in ax.get_xlabel()
    assert np.sort(ax.lines[0].get_xdata()) == pytest.approx(np.sort(used["heading_mag_deg"].to_numpy()))
    plt.close("all")
