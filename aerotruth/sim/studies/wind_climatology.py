"""Wind climatology of the truth atmosphere: how strong are the winds the truth flights
meet, level by level, over a network's region on the campaign's days?

One task per region × day: the day's TruthAtmosphere, seeded by the campaign seed and the
date (for a network's region, the very realization the campaign's truth flights on that
network fly through; an explicit box gets its own, centred on the box), is sampled at
`points` random positions, uniform over the area of the region box, at each flight level
and UTC hour. A flight level is a pressure altitude; its height above mean sea level
is found on the day's pressure profile at each point. Metrics per level: mean, RMS,
median, 95th percentile and maximum of the horizontal speed, mean u and v, RMS of w, and
the vector RMS of the mesoscale part (total minus synoptic wind; at flight levels the
boundary-layer factor is 1, so the difference is the mesoscale field alone); and per
region, period and level (`wind_by_region`) the mean, standard deviation, median and 95th
percentile of the speed with the mean u, v - the truth side of a climatology comparison
(flight levels 50, 180 and 300 are the 843, 506 and 301 hPa pressure altitudes, the
radiosonde's 850, 500 and 300 hPa within 10 hPa). `references:` lists cited
climatologies, each with its cells (region, period, level; the mean speed and its spread,
the median and 90th percentile of the speed, or the mean wind vector); the report puts
each beside the truth with their ratio and flags a judged statistic off by more than the
reference's `tolerance` (default 30 %) and by more than its `min_difference_kt` (default
5 kt); a reference standing in for a region it does not cover is `judged: false`, shown
only. Per reference j: `reference.j.cells_off`, the statistics the truth did not sample
(`reference.j.cells_unsampled`), and the RMS of log(truth / source) over its sampled speed
statistics (`reference.j.speed_rms_log_ratio`).
"""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from pydantic import Field, StrictInt, field_validator, model_validator

from aerotruth.schema import Section
from aerotruth.sim.campaign_file import Campaign, References
from aerotruth.sim.studies import Figure, Study, Summary
from aerotruth.sim.tasks import Task, weather_seed
from aerotruth.units import FT, KT

NETWORK_MARGIN_DEG = 1.0  # a network's region box extends this far beyond its airports


class RegionBox(Section):
    """A latitude/longitude box (degrees) sampled by the wind climatology: given as
    `lat_deg: [south, north]` and `lon_deg: [west, east]`, or as `network:` (the box around
    that route network's airports, NETWORK_MARGIN_DEG wider on each side)."""

    name: str = Field(min_length=1)
    network: str | None = None
    lat_deg: tuple[float, float] | None = None
    lon_deg: tuple[float, float] | None = None

    @model_validator(mode="after")
    def _ordered(self) -> RegionBox:
        if self.network is not None:
            if self.lat_deg is not None or self.lon_deg is not None:
                raise ValueError("give either network or lat_deg/lon_deg, not both")
            return self
        if self.lat_deg is None or self.lon_deg is None:
            raise ValueError("expected network: NAME or both lat_deg: [south, north] and lon_deg: [west, east]")
        (la0, la1), (lo0, lo1) = self.lat_deg, self.lon_deg
        if not (-90.0 <= la0 < la1 <= 90.0):
            raise ValueError(f"lat_deg: expected [south, north] within [-90, 90], got [{la0}, {la1}]")
        if not (-180.0 <= lo0 < lo1 <= 180.0):
            raise ValueError(f"lon_deg: expected [west, east] within [-180, 180], got [{lo0}, {lo1}]")
        return self


class ReferenceCell(Section):
    """One cell of a cited wind climatology for a region, period and flight level (the
    pressure altitude nearest the source's level): the mean wind speed (kt, with its spread
    where the source gives it), the median and 90th percentile of the speed (kt), or the
    mean wind vector (m/s east and north: what a climatological-mean model gives), or
    several of these."""

    region: str = Field(min_length=1)
    period: str = Field(min_length=1)
    flight_level: StrictInt = Field(ge=0, le=450)
    mean_speed_kt: float | None = Field(default=None, gt=0)
    sd_speed_kt: float | None = Field(default=None, gt=0)
    p50_speed_kt: float | None = Field(default=None, gt=0)
    p90_speed_kt: float | None = Field(default=None, gt=0)
    mean_u_mps: float | None = None
    mean_v_mps: float | None = None

    @model_validator(mode="after")
    def _one_statistic_at_least(self) -> ReferenceCell:
        if (self.mean_u_mps is None) != (self.mean_v_mps is None):
            raise ValueError("give both mean_u_mps and mean_v_mps (the mean wind vector), or neither")
        if self.mean_speed_kt is None and self.mean_u_mps is None and self.p50_speed_kt is None:
            raise ValueError("expected mean_speed_kt, p50_speed_kt, or mean_u_mps and mean_v_mps")
        if self.sd_speed_kt is not None and self.mean_speed_kt is None:
            raise ValueError("sd_speed_kt needs mean_speed_kt")
        if self.p90_speed_kt is not None and (self.p50_speed_kt is None or self.p90_speed_kt <= self.p50_speed_kt):
            raise ValueError("p90_speed_kt needs p50_speed_kt below it")
        return self


class ReferenceClimatology(Section):
    """A published climatology (radiosonde or reanalysis statistics, or an empirical model
    fitted to such data), cited, its cells shown beside the truth's and, when `judged`,
    each mean, median and 90th percentile flagged where the truth is off (the truth is never
    computed from them)."""

    source: str = Field(min_length=1, description="citation: who, what data, which years")
    judged: bool = Field(
        default=True,
        description="false: shown beside the truth, not judged (a source standing in for a region it does not "
        "cover, e.g. a station outside the region's box)",
    )
    tolerance: float = Field(
        default=0.30,
        gt=0,
        lt=1,
        description="flag a judged truth statistic off the source's by more than this fraction",
    )
    min_difference_kt: float = Field(
        default=5.0,
        ge=0,
        description="and by more than this: a relative test means nothing "
        "for a near-zero mean, and ~5 kt is the sampling error of a two-month regional mean "
        "(day-to-day sd ~20 kt over ~20 independent days)",
    )
    cells: list[ReferenceCell] = Field(min_length=1)


class WindClimatologyConfig(Section):
    """Wind statistics of the truth atmosphere: each region is sampled at random points at the
    given flight levels and UTC hours, one task per region and day."""

    regions: list[RegionBox] = Field(min_length=1)
    periods: list[str] = Field(min_length=1)
    references: list[ReferenceClimatology] = Field(
        default=[], description="cited climatologies shown beside the truth, each judged on its own tolerance"
    )
    flight_levels: list[StrictInt] = Field(
        default=[50, 100, 150, 200, 250], min_length=1, description="hundreds of feet"
    )
    hours_utc: list[float] = Field(default=[0.0, 6.0, 12.0, 18.0], min_length=1)
    points: StrictInt = Field(
        default=36, ge=1, le=1_000_000, description="random sample points per level and hour, uniform over the box area"
    )

    @field_validator("flight_levels")
    @classmethod
    def _levels(cls, v: list[int]) -> list[int]:
        for fl in v:
            if not 0 <= fl <= 450:
                raise ValueError(f"expected flight levels within 0..450, got {fl}")
        if len(set(v)) != len(v):
            raise ValueError("flight levels must be unique")
        return v

    @field_validator("hours_utc")
    @classmethod
    def _hours(cls, v: list[float]) -> list[float]:
        for h in v:
            if not 0.0 <= h < 24.0:
                raise ValueError(f"expected hours within [0, 24), got {h}")
        return v


def region_box(region: RegionBox) -> tuple[float, float, float, float]:
    """(south, north, west, east) in degrees: the given box, or the network's airports
    widened by NETWORK_MARGIN_DEG."""
    if region.network is None:
        return (*region.lat_deg, *region.lon_deg)  # type: ignore[misc]
    from aerotruth.truth.airports import airport, network

    net = network(region.network)
    lats = [airport(c).lat for c in net.airports]
    lons = [airport(c).lon for c in net.airports]
    m = NETWORK_MARGIN_DEG
    return (max(min(lats) - m, -90.0), min(max(lats) + m, 90.0), max(min(lons) - m, -180.0), min(max(lons) + m, 180.0))


def sample_points(
    rng: np.random.Generator, box: tuple[float, float, float, float], n: int
) -> tuple[np.ndarray, np.ndarray]:
    """n points uniform over the area of a lat/lon box: sin(lat) and lon uniform."""
    s, nn, w, e = box
    lat = np.degrees(np.arcsin(rng.uniform(math.sin(math.radians(s)), math.sin(math.radians(nn)), n)))
    lon = rng.uniform(w, e, n)
    return lat, lon


def atmosphere_region(region: RegionBox) -> str | tuple[float, float]:
    """Region key of the truth atmosphere: a network's region (the realization its truth
    flights fly through), or an explicit box's own realization centred on the box."""
    if region.network is not None:
        from aerotruth.truth.weather import NETWORK_REGION

        return NETWORK_REGION[region.network]
    s, n, w, e = region_box(region)
    return (0.5 * (s + n), 0.5 * (w + e))


class WindClimatology(Study):
    """The `wind_climatology` study (see the module docstring)."""

    name = "wind_climatology"
    title = "Wind climatology of the truth atmosphere"
    Config = WindClimatologyConfig

    def check(self, campaign: Campaign, refs: References) -> None:
        cfg = campaign.section(self.name)
        refs.periods()
        names = [r.name for r in cfg.regions]
        for i, n in enumerate(names):
            if names.index(n) != i:
                raise refs.error(("regions", i, "name"), f"duplicate name {n!r}")
        for j, ref in enumerate(cfg.references):
            for i, c in enumerate(ref.cells):
                for field, known in (("region", names), ("period", cfg.periods), ("flight_level", cfg.flight_levels)):
                    if getattr(c, field) not in known:
                        raise refs.error(
                            ("references", j, "cells", i, field),
                            f"expected one of the study's {field}s ({', '.join(map(str, known))}), "
                            f"got {refs.value(getattr(c, field))}",
                        )
        if any(r.network is not None for r in cfg.regions):
            from aerotruth.truth.airports import networks

            known = networks()
            for i, r in enumerate(cfg.regions):
                if r.network is not None and r.network not in known:
                    raise refs.error(
                        ("regions", i, "network"),
                        f"expected a route network ({', '.join(sorted(known))}), got {refs.value(r.network)}",
                    )

    def expand(self, campaign: Campaign, cfg: WindClimatologyConfig) -> list[Task]:
        days = campaign.days(cfg.periods)
        period_days = {p: set(campaign.days([p])) for p in cfg.periods}  # once per period, not per day
        member = {d: [p for p in cfg.periods if d in period_days[p]] for d in days}
        tasks = []
        for region in cfg.regions:
            box = region_box(region)
            for day in days:
                tasks.append(
                    Task(
                        self.name,
                        (("region", region.name), ("date", day.isoformat())),
                        params={
                            "box": box,
                            "atmosphere_region": atmosphere_region(region),
                            "weather_seed": weather_seed(campaign.seed, day),
                            "flight_levels": list(cfg.flight_levels),
                            "hours_utc": list(cfg.hours_utc),
                            "points": cfg.points,
                            "periods": member[day],
                        },
                    )
                )
        return tasks

    def cost(self, task: Task) -> float:
        """Run-time estimate (s): atmosphere set-up plus ~30 µs per sample (measured here)."""
        p = task.params
        return 0.3 + 3e-5 * p["points"] * len(p["flight_levels"]) * len(p["hours_utc"])

    def run(self, task: Task, ctx) -> pd.DataFrame:
        from aerotruth.truth.atmosphere import TruthAtmosphere

        ident = dict(task.identity)
        p = task.params
        day = dt.date.fromisoformat(str(ident["date"]))
        atm = TruthAtmosphere.for_day(day, p["weather_seed"], p["atmosphere_region"])
        n = int(p["points"])
        rng = ctx.rng("sample_points")
        frames = []
        for fl in p["flight_levels"]:
            for hour in p["hours_utc"]:
                lat, lon = sample_points(rng, p["box"], n)
                t_s = np.full(n, float(hour) * 3600.0)
                alt = msl_height_of_flight_level(atm, lat, lon, fl, t_s)
                u, v, w = (np.asarray(c, dtype=float) for c in atm.wind(lat, lon, alt, t_s))
                us, vs = (np.asarray(c, dtype=float) for c in atm.synoptic_wind(lat, lon, alt, t_s))
                frames.append(
                    pd.DataFrame(
                        {
                            "region": str(ident["region"]),
                            "date": day.isoformat(),
                            "flight_level": int(fl),
                            "hour_utc": float(hour),
                            "lat_deg": lat,
                            "lon_deg": lon,
                            "alt_msl_m": alt,
                            "u_mps": u,
                            "v_mps": v,
                            "w_mps": w,
                            "u_synoptic_mps": us,
                            "v_synoptic_mps": vs,
                            "periods": PERIOD_SEP.join(p.get("periods", [])),
                        }
                    )
                )
        return pd.concat(frames, ignore_index=True)

    def summarize(self, rows: pd.DataFrame, learned, section: WindClimatologyConfig) -> Summary:
        metrics = self._metrics(rows)
        by_region = wind_by_region(rows)
        for r in by_region.itertuples(index=False):
            key = f"{r.region}.{r.period}.FL{r.flight_level:03d}"
            metrics[f"{key}.speed_mean_mps"] = r.mean_mps
            metrics[f"{key}.speed_sd_mps"] = r.sd_mps
            metrics[f"{key}.speed_p50_mps"] = r.p50_mps
            metrics[f"{key}.speed_p90_mps"] = r.p90_mps
        tables = self._tables(metrics)
        tables["wind_by_region"] = _region_table(by_region)
        if section.references:
            vs = pd.concat(
                [versus_reference(by_region, ref, j) for j, ref in enumerate(section.references)], ignore_index=True
            )
            tables["versus_reference"] = vs
            for j, ref in enumerate(section.references):
                one = vs[vs["source_index"] == j]
                metrics[f"reference.{j}.cells"] = int(len(one))
                metrics[f"reference.{j}.judged"] = int(ref.judged)
                metrics[f"reference.{j}.cells_off"] = int(one["off"].sum())
                metrics[f"reference.{j}.tolerance"] = float(ref.tolerance)
                metrics[f"reference.{j}.min_difference_kt"] = float(ref.min_difference_kt)
                metrics[f"reference.{j}.cells_unsampled"] = int(one["truth"].isna().sum())
                ratio = one.loc[one["statistic"].isin(JUDGED_SPEED_STATISTICS), "ratio"].to_numpy(float)
                ratio = ratio[np.isfinite(ratio) & (ratio > 0)]
                if len(ratio):
                    metrics[f"reference.{j}.speed_rms_log_ratio"] = float(np.sqrt(np.mean(np.log(ratio) ** 2)))
        return Summary(metrics, tables)

    def _metrics(self, rows: pd.DataFrame) -> dict[str, Any]:
        out: dict[str, Any] = {"samples": int(len(rows)), "tasks": int(rows["task_id"].nunique()) if len(rows) else 0}
        for fl, g in _by_level(rows):
            speed = np.hypot(g["u_mps"].to_numpy(), g["v_mps"].to_numpy())
            key = f"FL{fl:03d}"
            out[f"{key}.speed_mean_mps"] = float(np.mean(speed))
            out[f"{key}.speed_rms_mps"] = float(np.sqrt(np.mean(speed**2)))
            out[f"{key}.speed_p50_mps"] = float(np.percentile(speed, 50))
            out[f"{key}.speed_p95_mps"] = float(np.percentile(speed, 95))
            out[f"{key}.speed_max_mps"] = float(np.max(speed))
            out[f"{key}.u_mean_mps"] = float(np.mean(g["u_mps"]))
            out[f"{key}.v_mean_mps"] = float(np.mean(g["v_mps"]))
            out[f"{key}.w_rms_mps"] = float(np.sqrt(np.mean(g["w_mps"].to_numpy() ** 2)))
            du = g["u_mps"].to_numpy() - g["u_synoptic_mps"].to_numpy()
            dv = g["v_mps"].to_numpy() - g["v_synoptic_mps"].to_numpy()
            out[f"{key}.mesoscale_vector_rms_mps"] = float(np.sqrt(np.mean(du**2 + dv**2)))
        return out

    def _tables(self, metrics: dict[str, Any]) -> dict[str, pd.DataFrame]:
        levels = sorted({int(k[2:5]) for k in metrics if k.startswith("FL")})
        table = pd.DataFrame(
            {
                "flight level": [f"FL{fl:03d}" for fl in levels],
                "mean speed (kt)": [metrics[f"FL{fl:03d}.speed_mean_mps"] / KT for fl in levels],
                "RMS speed (kt)": [metrics[f"FL{fl:03d}.speed_rms_mps"] / KT for fl in levels],
                "median (kt)": [metrics[f"FL{fl:03d}.speed_p50_mps"] / KT for fl in levels],
                "95 % (kt)": [metrics[f"FL{fl:03d}.speed_p95_mps"] / KT for fl in levels],
                "max (kt)": [metrics[f"FL{fl:03d}.speed_max_mps"] / KT for fl in levels],
                "mean u (m/s)": [metrics[f"FL{fl:03d}.u_mean_mps"] for fl in levels],
                "mean v (m/s)": [metrics[f"FL{fl:03d}.v_mean_mps"] for fl in levels],
                "RMS w (m/s)": [metrics[f"FL{fl:03d}.w_rms_mps"] for fl in levels],
                "mesoscale vector RMS (m/s)": [metrics[f"FL{fl:03d}.mesoscale_vector_rms_mps"] for fl in levels],
            }
        )
        return {"wind_by_level": table}

    def figures(self, rows: pd.DataFrame, summary: Summary, learned, out_dir: Path) -> list[Figure]:
        import matplotlib.pyplot as plt

        figs = []
        fig, ax = plt.subplots(figsize=(5.5, 4.5))
        for fl, g in _by_level(rows):
            speed = np.hypot(g["u_mps"], g["v_mps"]) / KT
            lo, med, hi = np.percentile(speed, [5, 50, 95])
            ax.plot([lo, hi], [fl, fl], color="0.6", lw=4, solid_capstyle="butt")
            ax.plot(med, fl, "ko")
            ax.plot(np.mean(speed), fl, "r|", ms=12)
        ax.set_xlabel("horizontal wind speed (kt): 5–95 % bar, median ●, mean |")
        ax.set_ylabel("flight level")
        ax.grid(alpha=0.3)
        ax.set_title("Truth wind speed by flight level")
        out_dir.save(fig, "wind_speed_by_level")
        figs.append(
            Figure(
                "wind_speed_by_level", "Horizontal truth wind speed by flight level over all regions, days and hours"
            )
        )

        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        for (region, fl), g in rows.groupby(["region", "flight_level"], sort=True):
            daily = g.assign(speed=np.hypot(g["u_mps"], g["v_mps"]) / KT).groupby("date", sort=True)["speed"].mean()
            ax.plot(pd.to_datetime(daily.index), daily.to_numpy(), marker=".", label=f"{region} FL{fl:03d}")
        import matplotlib.dates as mdates

        ax.xaxis.set_major_formatter(mdates.DateFormatter("%Y-%m-%d"))
        ax.set_ylabel("daily mean wind speed (kt)")
        ax.legend(fontsize="small", ncol=2)
        ax.grid(alpha=0.3)
        fig.autofmt_xdate()
        ax.set_title("Day-to-day variation of the truth wind")
        out_dir.save(fig, "wind_speed_by_day")
        figs.append(Figure("wind_speed_by_day", "Daily mean truth wind speed per region and flight level"))

        vs = summary.tables.get("versus_reference")
        if vs is not None and len(vs):
            stats = [k for k in REFERENCE_STATISTICS if k != "speed sd (kt)" and (vs["statistic"] == k).any()]
            fig, axes = plt.subplots(1, len(stats), figsize=(5.2 * len(stats), 4.8), squeeze=False)
            for ax, stat in zip(axes[0], stats, strict=False):
                g = vs[vs["statistic"] == stat]
                top = 1.1 * float(np.nanmax(np.r_[g["source"], g["truth"]]))
                x = np.linspace(0.0, top, 100)
                judged = sorted(set(g.loc[g["judged"].astype(bool), "source_index"]))
                if judged:  # the band of the references judged in this panel
                    j = int(judged[0])
                    tol = float(summary.metrics.get(f"reference.{j}.tolerance", 0.3))
                    floor_kt = float(summary.metrics.get(f"reference.{j}.min_difference_kt", 0.0))
                    band = np.maximum(tol * x, floor_kt * REFERENCE_STATISTICS[stat])
                    ax.fill_between(x, x - band, x + band, color="0.9", label=f"within {tol:.0%} or {floor_kt:g} kt")
                ax.plot(x, x, "k-", lw=0.8)
                for fl, marker in zip(sorted(g["flight_level"].unique()), "o^sDv", strict=False):
                    h = g[(g["flight_level"] == fl) & g["judged"].astype(bool)]
                    ax.scatter(
                        h["source"],
                        h["truth"],
                        marker=marker,
                        label=fl,
                        c=["tab:red" if o else "tab:green" for o in h["off"]],
                        edgecolors="k",
                        linewidths=0.4,
                    )
                    h = g[(g["flight_level"] == fl) & ~g["judged"].astype(bool)]
                    if len(h):
                        ax.scatter(
                            h["source"],
                            h["truth"],
                            marker=marker,
                            facecolors="none",
                            edgecolors="0.4",
                            linewidths=0.6,
                            label=f"{fl} (shown)",
                        )
                ax.set_xlim(0, top)
                ax.set_ylim(0, top)
                ax.set_xlabel(f"source: {stat}")
                ax.set_ylabel(f"truth: {stat}")
                ax.grid(alpha=0.3)
                ax.legend(fontsize="x-small", title="red: off; hollow: not judged")
            names = "; ".join(dict.fromkeys(str(r).split(" (")[0].split(":")[0] for r in vs["reference"]))
            fig.suptitle(f"Truth atmosphere vs {names}", fontsize=8)
            out_dir.save(fig, "wind_versus_reference")
            figs.append(
                Figure(
                    "wind_versus_reference",
                    "Truth wind statistics against the cited climatologies, per region, "
                    "season and level (red: off by more than the tolerance)",
                )
            )
        return figs


PERIOD_SEP = "|"  # joins the names of the periods a sampled day belongs to
# the statistics a reference cell may give, with the size of 1 kt in each one's unit
REFERENCE_STATISTICS = {
    "mean wind vector (m/s)": KT,
    "mean speed (kt)": 1.0,
    "speed sd (kt)": 1.0,
    "median speed (kt)": 1.0,
    "90 % speed (kt)": 1.0,
}
JUDGED_SPEED_STATISTICS = ("mean speed (kt)", "median speed (kt)", "90 % speed (kt)")


def wind_by_region(rows: pd.DataFrame) -> pd.DataFrame:
    """Speed statistics (m/s) per region, period and flight level: samples, mean, standard
    deviation (ddof 1), median, 90th and 95th percentiles, mean u and v, first and last date. A day in
    several periods counts in each."""
    cols = [
        "region",
        "period",
        "flight_level",
        "samples",
        "mean_mps",
        "sd_mps",
        "p50_mps",
        "p90_mps",
        "p95_mps",
        "u_mean_mps",
        "v_mean_mps",
        "first_date",
        "last_date",
    ]
    if not len(rows) or "periods" not in rows.columns:
        return pd.DataFrame(columns=cols)
    df = rows[["region", "flight_level", "date", "u_mps", "v_mps", "periods"]].copy()
    df["period"] = df.pop("periods").astype(str).str.split(PERIOD_SEP, regex=False)
    df = df.explode("period")
    df = df[df["period"] != ""]
    df["speed"] = np.hypot(df["u_mps"].to_numpy(float), df["v_mps"].to_numpy(float))
    out = []
    for (region, period, fl), g in df.groupby(["region", "period", "flight_level"], sort=True):
        sp = g["speed"].to_numpy()
        out.append(
            {
                "region": region,
                "period": period,
                "flight_level": int(fl),
                "samples": len(sp),
                "mean_mps": float(sp.mean()),
                "sd_mps": float(sp.std(ddof=1)) if len(sp) > 1 else math.nan,
                "p50_mps": float(np.percentile(sp, 50)),
                "p90_mps": float(np.percentile(sp, 90)),
                "p95_mps": float(np.percentile(sp, 95)),
                "u_mean_mps": float(g["u_mps"].mean()),
                "v_mean_mps": float(g["v_mps"].mean()),
                "first_date": str(g["date"].min()),
                "last_date": str(g["date"].max()),
            }
        )
    return pd.DataFrame(out, columns=cols)


def _region_table(by_region: pd.DataFrame) -> pd.DataFrame:
    """wind_by_region for the report: speeds in knots, the level's ISA pressure."""
    from aerotruth.truth.isa import isa_pressure_pa

    b = by_region
    return pd.DataFrame(
        {
            "region": b["region"],
            "period": b["period"],
            "days": [f"{a} - {z}" for a, z in zip(b["first_date"], b["last_date"], strict=False)],
            "flight level": [f"FL{fl:03d}" for fl in b["flight_level"]],
            "pressure (hPa)": [round(float(isa_pressure_pa(fl * 100.0 * FT)) / 100.0) for fl in b["flight_level"]],
            "samples": b["samples"],
            "mean speed (kt)": b["mean_mps"] / KT,
            "sd (kt)": b["sd_mps"] / KT,
            "median (kt)": b["p50_mps"] / KT,
            "90 % (kt)": b["p90_mps"] / KT,
            "95 % (kt)": b["p95_mps"] / KT,
            "mean u (m/s)": b["u_mean_mps"],
            "mean v (m/s)": b["v_mean_mps"],
        }
    )


def versus_reference(by_region: pd.DataFrame, ref: ReferenceClimatology, index: int = 0) -> pd.DataFrame:
    """Each cited statistic beside the truth's, one row per cell and statistic: the mean
    speed (kt), its spread (kt), the median and 90th percentile of the speed (kt), the mean
    wind vector's magnitude (m/s, with the truth's and the source's u, v), the ratio truth
    / source, and `off` where a judged statistic (a mean, the median or the 90th
    percentile) is outside the source's by more than the tolerance and by more than
    `min_difference_kt`; a cell the truth did not sample is off, its truth NaN. The spread
    is shown, not judged; a reference with `judged: false` is shown, its `off` always
    false. `source_index` numbers the reference (its place in `references`)."""
    idx = by_region.set_index(["region", "period", "flight_level"]) if len(by_region) else None
    rows = []
    for c in ref.cells:
        key = (c.region, c.period, c.flight_level)
        t = idx.loc[key] if idx is not None and key in idx.index else None
        get = (lambda col, t=t: float(t[col])) if t is not None else (lambda col: math.nan)
        base = {"region": c.region, "period": c.period, "flight_level": f"FL{c.flight_level:03d}"}
        stats = []
        if c.mean_speed_kt is not None:
            stats.append(("mean speed (kt)", c.mean_speed_kt, get("mean_mps") / KT, True, {}))
        if c.sd_speed_kt is not None:
            stats.append(("speed sd (kt)", c.sd_speed_kt, get("sd_mps") / KT, False, {}))
        if c.p50_speed_kt is not None:
            stats.append(("median speed (kt)", c.p50_speed_kt, get("p50_mps") / KT, True, {}))
        if c.p90_speed_kt is not None:
            stats.append(("90 % speed (kt)", c.p90_speed_kt, get("p90_mps") / KT, True, {}))
        if c.mean_u_mps is not None:
            tu, tv = get("u_mean_mps"), get("v_mean_mps")
            stats.append(
                (
                    "mean wind vector (m/s)",
                    math.hypot(c.mean_u_mps, c.mean_v_mps),
                    math.hypot(tu, tv),
                    True,
                    {"source_u_mps": c.mean_u_mps, "source_v_mps": c.mean_v_mps, "truth_u_mps": tu, "truth_v_mps": tv},
                )
            )
        for name, src, tru, judged, extra in stats:
            ratio = tru / src if src > 0 else math.nan
            floor = ref.min_difference_kt * REFERENCE_STATISTICS[name]
            rows.append(
                {
                    **base,
                    "statistic": name,
                    "source": src,
                    "truth": tru,
                    "ratio": ratio,
                    "off": bool(ref.judged and judged and not (abs(tru - src) <= max(ref.tolerance * src, floor))),
                    **{
                        k: extra.get(k, math.nan)
                        for k in ("source_u_mps", "source_v_mps", "truth_u_mps", "truth_v_mps")
                    },
                }
            )
    return pd.DataFrame(rows).assign(reference=ref.source, source_index=index, judged=ref.judged)


def _by_level(rows: pd.DataFrame):
    """(flight level, rows) in level order; rows keep their task-id order."""
    if not len(rows):
        return []
    return [(int(fl), g) for fl, g in rows.groupby("flight_level", sort=True)]


def msl_height_of_flight_level(
    atm, lat: np.ndarray, lon: np.ndarray, flight_level: int, t_s: np.ndarray, iterations: int = 4
) -> np.ndarray:
    """Geometric height above mean sea level (m) where the day's static pressure equals
    that of the flight level (pressure altitude FL x 100 ft). Newton-like iteration on the
    hypsometric relation: a layer of the ISA + dT column is T / T_ISA times as thick as
    the same layer of the standard atmosphere, so
    z <- z + (PA_target - PA(p(z))) * T(z) / T_ISA(PA(p(z))) (ICAO Doc 7488 ISA)."""
    from aerotruth.truth.isa import (
        geometric_altitude_m,
        isa_temperature_k,
        pressure_altitude_m,
    )

    target = flight_level * 100.0 * FT
    z = np.full(np.shape(lat), float(geometric_altitude_m(target)))
    for _ in range(iterations):
        temp, p = (np.asarray(a, dtype=float) for a in atm.temperature_and_pressure(lat, lon, z, t_s))
        pa = np.asarray(pressure_altitude_m(p), dtype=float)
        z = z + (target - pa) * temp / np.asarray(isa_temperature_k(pa), dtype=float)
    return z


STUDY = WindClimatology()
