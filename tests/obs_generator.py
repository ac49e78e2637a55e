"""Independent synthetic generator of aircraft wind reports (observation tables) with a
known heading deviation, for testing the wind paper's method. It uses none of
aerotruth's truth, sensor or analysis code: geodesy through pyproj, the rest here.

What it simulates, per flight (hub-and-spoke: out to a spoke, back to the hub):

* the route is the WGS-84 geodesic hub -> spoke; the aircraft climbs at 1500 ft/min to a
  cruise level, cruises, descends at 1500 ft/min; TAS ramps from 0.6 x cruise TAS on the
  ground to the aircraft's cruise TAS at its level; ground speed from the wind triangle, integrated along the route
  on a 5-s grid; true heading = direction of V_A = V_G - V_W (no crab errors);
* truth wind per flight: a random base vector, stronger with altitude, with a slow
  40-min oscillation of 2 m/s;
* the measured heading psi_m solves psi_m = psi_true + d(psi_m - declination) with
  d = A + B sin z' + C cos z' + D sin 2z' + E cos 2z' (wind paper eq. 2, z' the measured
  magnetic heading), plus 0.1 deg white noise; TAS measured with 0.5 kt white noise;
* the onboard (TAMDAR) wind is V_W = V_G - V_A(psi_m, TAS_m) with the instantaneous GPS
  ground velocity (wind paper eq. 1), i.e. computed from the deviated heading;
* reports as TAMDAR sends them: every 10 hPa up to 100 hPa above ground, then every
  50 hPa, or after 3 min (below 20,000 ft) / 7 min (above) without one; lat/lon rounded
  to 0.01 deg, wind speed to 1 kt and direction to 1 deg; no heading, no TAS unless asked;
* reference models: truth wind + an error per model, per component an Ornstein-Uhlenbeck
  process (4 kt standard deviation, 30-min e-folding time) restarted each flight,
  independent between models; one row per (report, model) with `ref_source`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from pyproj import Geod

KT_MS = 1852.0 / 3600.0
FT_M = 0.3048
HUB = (44.88, -93.22)  # lat, lon of the hub (Minneapolis)
GEOD = Geod(ellps="WGS84")


@dataclass(frozen=True)
class AircraftTruth:
    """The hidden deviation of one aircraft (degrees, function of magnetic measured heading)."""

    aircraft: str
    A: float
    B: float
    C: float
    D: float = 0.0
    E: float = 0.0
    cruise_tas_kt: float = 280.0
    one_heading: bool = False
    h0_nT: float | None = None  # when set, B and C are hard iron: scaled by h0 / H at each position (IGRF)
    tas_scale: float = 0.0  # TAS reads (1 + tas_scale) x true
    a_step_deg: float = 0.0  # the offset A changes by this from the middle flight on (a recalibration)
    a_drift_deg_per_day: float = 0.0  # the offset A changes linearly in time at this rate (from the dataset's start)
    spoke: int | None = None  # fly out and back on this one spoke only (two headings)

    def deviation(self, z_deg: np.ndarray, h_nT: np.ndarray | float | None = None) -> np.ndarray:
        z = np.radians(z_deg)
        k = 1.0 if self.h0_nT is None or h_nT is None else self.h0_nT / np.asarray(h_nT)
        return self.A + k * (self.B * np.sin(z) + self.C * np.cos(z)) + self.D * np.sin(2 * z) + self.E * np.cos(2 * z)


class FieldGrid:
    """IGRF (ppigrf, independent of aerotruth) at one date on a 0.25-deg lat/lon grid at
    0-45,000 ft over a network's box, linear in between (scipy): one ppigrf call for a
    whole dataset instead of one per flight. Against ppigrf point by point on a 700-km
    climbing track out of Anchorage: H within 0.21 nT, declination within 0.0003 deg; the
    field drifts 2.3 nT in 100 days there (2009), so the dataset's start date serves all
    its days (<= 120)."""

    STEP_DEG = 0.25
    ALT_FT = np.array([0.0, 15000.0, 30000.0, 45000.0])

    def __init__(self, lat: tuple[float, float], lon: tuple[float, float], t_epoch: float):
        import datetime as dt

        import ppigrf
        from scipy.interpolate import RegularGridInterpolator

        lats = np.arange(lat[0], lat[1] + self.STEP_DEG, self.STEP_DEG)
        lons = np.arange(lon[0], lon[1] + self.STEP_DEG, self.STEP_DEG)
        when = dt.datetime(1970, 1, 1) + dt.timedelta(seconds=float(t_epoch))
        la, lo, al = np.meshgrid(lats, lons, self.ALT_FT, indexing="ij")
        be, bn, _ = ppigrf.igrf(lo, la, al * FT_M / 1000.0, when)
        self._east = RegularGridInterpolator((lats, lons, self.ALT_FT), be[0])
        self._north = RegularGridInterpolator((lats, lons, self.ALT_FT), bn[0])

    @classmethod
    def over(cls, points: list[tuple[float, float]], t_epoch: float, margin_deg: float = 1.0) -> FieldGrid:
        """A grid over the box of `points` (lat, lon) with a margin: a geodesic between two of
        them bulges < 0.3 deg poleward of their box at 900 km."""
        lat, lon = np.array(points).T
        return cls(
            (lat.min() - margin_deg, lat.max() + margin_deg), (lon.min() - margin_deg, lon.max() + margin_deg), t_epoch
        )

    def _at(self, lat, lon, alt_ft) -> tuple[np.ndarray, np.ndarray]:
        pts = np.column_stack([lat, lon, np.clip(alt_ft, self.ALT_FT[0], self.ALT_FT[-1])])
        return self._east(pts), self._north(pts)

    def horizontal_nT(self, lat, lon, alt_ft) -> np.ndarray:
        be, bn = self._at(lat, lon, alt_ft)
        return np.hypot(be, bn)

    def declination_deg(self, lat, lon, alt_ft) -> np.ndarray:
        be, bn = self._at(lat, lon, alt_ft)
        return np.degrees(np.arctan2(be, bn))


def fleet(
    n: int,
    rng: np.random.Generator,
    *,
    de_every: int = 3,
    one_heading_last: bool = True,
    tas_kt: tuple[float, float] = (260.0, 300.0),
) -> list[AircraftTruth]:
    """n aircraft: offsets U(-3, 3) deg, sinusoid amplitude U(0.5, 3) deg at a random phase;
    every `de_every`-th aircraft also has D, E of amplitude U(0.6, 1.2) deg; the last one
    (if asked) flies one heading only."""
    out = []
    for i in range(n):
        amp, ph = rng.uniform(0.5, 3.0), rng.uniform(0, 2 * np.pi)
        d = e = 0.0
        if de_every and i % de_every == 1:
            amp2, ph2 = rng.uniform(0.6, 1.2), rng.uniform(0, 2 * np.pi)
            d, e = amp2 * np.cos(ph2), amp2 * np.sin(ph2)
        out.append(
            AircraftTruth(
                f"N{401 + i}XJ",
                float(rng.uniform(-3, 3)),
                float(amp * np.cos(ph)),
                float(amp * np.sin(ph)),
                float(d),
                float(e),
                float(rng.uniform(*tas_kt)),
                one_heading_last and i == n - 1,
            )
        )
    return out


def declination(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """A smooth made-up declination field (deg east): +1 deg at the hub, 0.5 deg less per
    degree of longitude eastwards."""
    return 1.0 - 0.5 * (np.asarray(lon) - HUB[1]) + 0.1 * (np.asarray(lat) - HUB[0])


def _pressure_hpa(alt_ft: np.ndarray) -> np.ndarray:
    return 1013.25 * (1.0 - 6.87559e-6 * alt_ft) ** 5.25588  # ISA troposphere in feet


def _spokes(rng: np.random.Generator, km: tuple[float, float], n: int = 16, hub=HUB) -> list[tuple[float, float]]:
    """Spoke airports around the hub: bearings spread round the compass, distances U(km)."""
    bearings = (np.arange(n) * 360.0 / n + rng.uniform(0, 360.0 / n, n)) % 360.0
    dists = rng.uniform(km[0] * 1e3, km[1] * 1e3, n)
    lon, lat, _ = GEOD.fwd(np.full(n, hub[1]), np.full(n, hub[0]), bearings, dists)
    return list(zip(lat, lon, strict=False))


def _fly(
    a: AircraftTruth,
    start: tuple[float, float],
    end: tuple[float, float],
    t0: float,
    rng: np.random.Generator,
    cruise_ft_range: tuple[float, float],
    wind_ms: tuple[float, float] = (5.0, 25.0),
    wind_from_deg: float | None = None,
) -> dict[str, np.ndarray]:
    """5-s samples of one flight: time, position, altitude, truth wind (low-level speed drawn
    in `wind_ms`, from a random direction or `wind_from_deg`), V_G, true heading, TAS."""
    az0, _, dist = GEOD.inv(start[1], start[0], end[1], end[0])
    cruise_ft = rng.uniform(*cruise_ft_range)
    rate_fps = 1500.0 / 60.0
    t_climb = cruise_ft / rate_fps
    w_speed, w_dir = rng.uniform(*wind_ms), rng.uniform(0, 2 * np.pi)
    if wind_from_deg is not None:  # a prevailing wind: towards the opposite direction
        w_dir = np.radians(wind_from_deg + 180.0)
    w0 = w_speed * np.array([np.sin(w_dir), np.cos(w_dir)])
    osc_phase = rng.uniform(0, 2 * np.pi, 2)
    tas_cruise = a.cruise_tas_kt * KT_MS

    def profile(total_s: float):
        t = np.arange(0.0, total_s, 5.0)
        alt = np.minimum(np.minimum(t, total_s - t) * rate_fps, cruise_ft)
        alt = np.maximum(alt, 0.0)
        tas = tas_cruise * (0.6 + 0.4 * alt / cruise_ft)
        wind = w0[None, :] * (1.0 + 0.5 * alt[:, None] * FT_M / 6000.0) + 2.0 * np.sin(
            2 * np.pi * t[:, None] / 2400.0 + osc_phase[None, :]
        )
        return t, alt, tas, wind

    total = 2 * t_climb + max(dist - 2 * t_climb * 0.8 * tas_cruise, 0.0) / tas_cruise
    for _ in range(4):  # adjust the cruise time until the integrated distance is the route length
        t, alt, tas, wind = profile(total)
        course = np.radians(az0)
        along = np.array([np.sin(course), np.cos(course)])
        w_along = wind @ along
        w_perp = wind @ np.array([np.cos(course), -np.sin(course)])
        gs = np.sqrt(np.maximum(tas**2 - w_perp**2, 1.0)) + w_along
        s = np.concatenate([[0.0], np.cumsum(0.5 * (gs[1:] + gs[:-1]) * 5.0)])
        total += (dist - s[-1]) / max(np.mean(gs), 50.0)
    keep = s <= dist
    t, alt, tas, wind, gs, s = t[keep], alt[keep], tas[keep], wind[keep], gs[keep], s[keep]
    lon, lat, back = GEOD.fwd(np.full(len(s), start[1]), np.full(len(s), start[0]), np.full(len(s), az0), s)
    course = np.radians((np.asarray(back) + 180.0) % 360.0)
    vg = gs[:, None] * np.column_stack([np.sin(course), np.cos(course)])
    va = vg - wind  # wind paper eq. 1, truth
    psi_true = np.degrees(np.arctan2(va[:, 0], va[:, 1])) % 360.0
    phase = np.where(t < t_climb, "ascent", np.where(t > t[-1] - t_climb, "descent", "level"))
    return dict(
        time=t0 + t,
        lat=np.asarray(lat),
        lon=np.asarray(lon),
        alt_ft=alt,
        wind=wind,
        vg=vg,
        psi_true=psi_true,
        tas=np.hypot(va[:, 0], va[:, 1]),
        phase=phase,
    )


def _report_indices(alt_ft: np.ndarray, t: np.ndarray) -> np.ndarray:
    """TAMDAR reporting: 10 hPa steps up to 100 hPa above ground, then 50 hPa, else 3/7 min."""
    p = _pressure_hpa(alt_ft)
    p_ground = p[0]
    idx = [0]
    p_r, t_r = p[0], t[0]
    for k in range(1, len(t)):
        step = 10.0 if p_ground - p[k] < 100.0 else 50.0
        wait = 180.0 if alt_ft[k] < 20000.0 else 420.0
        if abs(p[k] - p_r) >= step or t[k] - t_r >= wait:
            idx.append(k)
            p_r, t_r = p[k], t[k]
    return np.asarray(idx)


def _ou(times: np.ndarray, sigma: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    """Two independent OU components at the given times (exact discretisation); tau = 0: white."""
    out = np.empty((len(times), 2))
    out[0] = rng.normal(0.0, sigma, 2)
    for k in range(1, len(times)):
        phi = np.exp(-(times[k] - times[k - 1]) / tau) if tau > 0 else 0.0
        out[k] = phi * out[k - 1] + sigma * np.sqrt(1 - phi**2) * rng.normal(size=2)
    return out


def along_unit(wind: np.ndarray) -> np.ndarray:
    """Unit vectors along (n, 2) wind vectors."""
    return wind / np.maximum(np.hypot(wind[:, 0], wind[:, 1]), 1e-9)[:, None]


def _from_dir(vec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speed (kt) and meteorological direction ("from", deg) of towards-vectors (m/s)."""
    speed = np.hypot(vec[:, 0], vec[:, 1]) / KT_MS
    return speed, np.degrees(np.arctan2(-vec[:, 0], -vec[:, 1])) % 360.0


def generate(
    truths: list[AircraftTruth],
    rng: np.random.Generator,
    *,
    flights: int = 40,
    models: tuple[str, ...] = ("rr", "rtfdda"),
    ref_sigma_kt: float = 4.0,
    ref_tau_s: float = 1800.0,
    quant_deg: float = 0.01,
    include_heading: bool = False,
    t_start: float = 1_249_084_800.0,
    spoke_km: tuple[float, float] = (250.0, 650.0),
    cruise_ft: tuple[float, float] = (12000.0, 22000.0),
    exact: bool = False,
    hub: tuple[float, float] = HUB,
    stale_declination_years: float = 0.0,
    ref_bias_kt: dict[str, float] | None = None,
    ref_scale: dict[str, float] | None = None,
    alt_error_deg_per_kft: float = 0.0,
    shared_ref_sigma_kt: float = 0.0,
    shared_ref_tau_s: float = 3 * 3600.0,
    wind_ms: tuple[float, float] = (5.0, 25.0),
    wind_from_deg: float | None = None,
) -> pd.DataFrame:
    """An observation table: one row per (report, reference model). Defaults: a SAAB-340-like
    turboprop network; regional jets: spoke_km (400, 1000), cruise_ft (25000, 35000) and
    fleet(tas_kt=(400, 450)). exact=True: no onboard heading/TAS/GPS noise and no rounding of
    the reported winds, so the reference-model error is the only noise (Cramer-Rao checks).

    Hidden effects beyond the deviation (for diagnose): `stale_declination_years` adds the
    declination change over that many years (IGRF via ppigrf: D(t - years) - D(t), t the
    dataset's start; FieldGrid) to the measured true heading; `ref_bias_kt` {model: b} adds
    b kt along the true wind to that model's analysis, `ref_scale` {model: s} s times the true
    wind (a model too strong by s); `alt_error_deg_per_kft` adds a heading error growing with
    pressure altitude (an effect outside diagnose's library); AircraftTruth.tas_scale,
    a_step_deg and a_drift_deg_per_day.

    `wind_ms`: the range of each flight's low-level wind speed (m/s; it grows by half at
    6 km, plus a 2-m/s oscillation); `wind_from_deg`: every flight's wind from that direction
    (a prevailing wind), else from a random one.

    `shared_ref_sigma_kt`: each model's analysis also errs in wind speed by an amount common
    to every aircraft at the same time (an OU process in time, e-folding `shared_ref_tau_s`,
    along each report's true wind): the analysis is one field, so aircraft flying in the
    same hours share its error; its mean over the data is zero (no bias)."""
    spokes = _spokes(rng, spoke_km, hub=hub)
    ref_bias_kt, ref_scale = ref_bias_kt or {}, ref_scale or {}
    field = stale = None
    if any(a.h0_nT is not None for a in truths) or stale_declination_years:
        field = FieldGrid.over([hub, *spokes], t_start)
    if stale_declination_years:
        stale = FieldGrid.over([hub, *spokes], t_start - stale_declination_years * 365.25 * 86400.0)
    grid = t_start + np.arange(0.0, 120 * 86400.0, 600.0)
    shared = {
        m: _ou(grid, shared_ref_sigma_kt * KT_MS, shared_ref_tau_s, rng) if shared_ref_sigma_kt else None
        for m in models
    }
    cols: dict[str, list[np.ndarray]] = {}  # the table's columns, piece by piece (one DataFrame at the end)
    for a in truths:
        t0 = t_start + rng.uniform(0, 3600)
        fixed = spokes[3]
        order = np.concatenate([rng.permutation(len(spokes)) for _ in range(flights // (2 * len(spokes)) + 1)])
        for f in range(flights):
            if a.one_heading:
                start, end = hub, fixed
            elif a.spoke is not None:
                start, end = (hub, spokes[a.spoke]) if f % 2 == 0 else (spokes[a.spoke], hub)
            else:  # the aircraft rotates through the spokes: out, back, next spoke
                spoke = spokes[order[f // 2]]
                start, end = (hub, spoke) if f % 2 == 0 else (spoke, hub)
            fl = _fly(a, start, end, t0, rng, cruise_ft, wind_ms, wind_from_deg)
            t0 = fl["time"][-1] + rng.uniform(2400, 20000)
            psi_t = fl["psi_true"]
            decl = declination(fl["lat"], fl["lon"])
            psi_m = psi_t.copy()
            h_nt = None if a.h0_nT is None else field.horizontal_nT(fl["lat"], fl["lon"], fl["alt_ft"])
            step = (a.a_step_deg if f >= flights // 2 else 0.0) + a.a_drift_deg_per_day * (
                fl["time"] - t_start
            ) / 86400.0
            for _ in range(8):  # fixed point of psi_m = psi_true + d(psi_m - decl)
                psi_m = psi_t + a.deviation(psi_m - decl, h_nt) + step
            if stale_declination_years:
                # what a receiver with a declination model `years` old adds to the true heading it reports
                psi_m = psi_m + (
                    stale.declination_deg(fl["lat"], fl["lon"], fl["alt_ft"])
                    - field.declination_deg(fl["lat"], fl["lon"], fl["alt_ft"])
                )
            if alt_error_deg_per_kft:
                psi_m = psi_m + alt_error_deg_per_kft * fl["alt_ft"] / 1000.0
            noise = 0.0 if exact else 1.0
            psi_m = (psi_m + noise * rng.normal(0, 0.1, len(psi_m))) % 360.0
            tas_m = (1.0 + a.tas_scale) * fl["tas"] + noise * rng.normal(0, 0.5 * KT_MS, len(psi_m))
            va_m = tas_m[:, None] * np.column_stack([np.sin(np.radians(psi_m)), np.cos(np.radians(psi_m))])
            w_onboard = fl["vg"] + noise * rng.normal(0, 0.1, fl["vg"].shape) - va_m  # wind paper eq. 1 onboard
            k = _report_indices(fl["alt_ft"], fl["time"])
            spd, drc = _from_dir(w_onboard[k])
            base = dict(
                aircraft=a.aircraft,
                time=fl["time"][k],
                lat=np.round(fl["lat"][k] / quant_deg) * quant_deg,
                lon=np.round(fl["lon"][k] / quant_deg) * quant_deg,
                pressure_altitude_ft=np.round(fl["alt_ft"][k], -1),
                wind_speed_kt=spd if exact else np.round(spd),
                wind_dir_deg=drc if exact else np.round(drc) % 360.0,
                roll_deg=np.round(rng.normal(0, 1.0, len(k)), 1),
                phase=fl["phase"][k],
                declination_deg=np.round(decl[k], 2),
            )
            if include_heading:
                base["heading_deg"] = np.round(psi_m[k], 2)
                base["tas_kt"] = np.round(tas_m[k] / KT_MS, 1)
            for m in models:
                err = _ou(fl["time"][k], ref_sigma_kt * KT_MS, ref_tau_s, rng)
                if shared[m] is not None:
                    err = err + np.interp(fl["time"][k], grid, shared[m][:, 0])[:, None] * along_unit(fl["wind"][k])
                wk = fl["wind"][k]
                rs, rd = _from_dir(
                    wk * (1.0 + ref_scale.get(m, 0.0)) + err + ref_bias_kt.get(m, 0.0) * KT_MS * along_unit(wk)
                )
                piece = {
                    **base,
                    "ref_wind_speed_kt": np.round(rs, 2),
                    "ref_wind_dir_deg": np.round(rd, 2),
                    "ref_source": m,
                }
                for c, v in piece.items():
                    cols.setdefault(c, []).append(np.full(len(k), v, dtype=object) if np.isscalar(v) else v)
    return pd.DataFrame({c: np.concatenate(v) for c, v in cols.items()})


def truth_table(truths: list[AircraftTruth]) -> pd.DataFrame:
    """The hidden coefficients, one row per aircraft."""
    return pd.DataFrame([a.__dict__ for a in truths]).set_index("aircraft")


def add_reference_field(
    obs: pd.DataFrame, seed: int, sd_kt: float = 6.0, l_km: float = 200.0, l_h: float = 3.0, modes: int = 200
) -> pd.DataFrame:
    """The observation table with each reference model's wind moved by an error field the
    aircraft share (a draw per model, seeded by `seed`): east and north each a sum of `modes`
    random cosines (random Fourier features, wavenumbers N(0, 1/l^2) in x, y and time), a
    Gaussian covariance of sd_kt^2 with lengths l_km and l_h hours, evaluated at the rows'
    positions and times."""
    rng = np.random.default_rng([seed, 7])
    obs = obs.copy()
    x = (obs["lon"].to_numpy() + 93.0) * 111.195 * np.cos(np.radians(45.0))
    y = (obs["lat"].to_numpy() - 45.0) * 111.195
    t = (obs["time"].to_numpy() - obs["time"].min()) / 3600.0
    for src in obs["ref_source"].unique():
        s = obs["ref_source"].to_numpy() == src
        comp = []
        for _ in range(2):
            kx, ky, w = rng.normal(0, 1 / l_km, modes), rng.normal(0, 1 / l_km, modes), rng.normal(0, 1 / l_h, modes)
            arg = np.outer(x[s], kx) + np.outer(y[s], ky) + np.outer(t[s], w) + rng.uniform(0, 2 * np.pi, modes)
            comp.append(sd_kt * np.sqrt(2.0 / modes) * np.cos(arg).sum(axis=1))
        speed, wdir = obs.loc[s, "ref_wind_speed_kt"].to_numpy(), np.radians(obs.loc[s, "ref_wind_dir_deg"].to_numpy())
        u, v = -speed * np.sin(wdir) + comp[0], -speed * np.cos(wdir) + comp[1]
        obs.loc[s, "ref_wind_speed_kt"] = np.hypot(u, v)
        obs.loc[s, "ref_wind_dir_deg"] = np.degrees(np.arctan2(-u, -v)) % 360.0
    return obs
