"""A second independent generator of observation tables (docs/data-formats.md, "Observation
table"): straight, constant-course flights of a regional fleet with a known heading
deviation, for testing `aerotruth diagnose` on data it was not built with. It imports
nothing from aerotruth (numpy and pandas only) and shares no code with tests/obs_generator.py.

What it simulates:

* 12 aircraft (`aircraft`) over `days` days. 14 "cities" drawn in a box of +-4.5 deg lat,
  +-6 deg lon round 45N 93W (~1000 km); each aircraft flies legs between random city
  pairs 200-1000 km apart, from 10:00 UTC on, with 40-100 min on the ground between
  legs, until 04:00 UTC; then it rests until the next day.
* Each leg is a rhumb line (constant true course, course from the spherical Mercator
  formula), integrated on the WGS-84 ellipsoid on a 10-s grid (it ends within a few km of
  the destination). Profile: from 2000 ft climb at 1500 ft/min to the leg's cruise
  level U(14000, 24000) ft, cruise, descend at 1500 ft/min to 2000 ft. TAS rises
  linearly with altitude from 0.6 x cruise TAS at 2000 ft to the aircraft's cruise TAS
  U(240, 290) kt at the cruise level (falls the same way in the descent). The TAS is
  the horizontal airspeed (the air vector of the wind triangle; no 3-D/horizontal
  distinction); the pressure altitude is the altitude (ISA).
* Truth wind (towards-vector, m/s): a westerly of 10 + 30 x min(h / 24000 ft, 1) m/s
  plus four non-divergent travelling waves (stream function; wavelengths 1500-4000 km,
  periods 1.5-5 days, each 2-6 m/s) that grow by half from the ground to 24000 ft.
  Ground velocity from the wind triangle along the constant course; true heading =
  direction of V_A = V_G - W.
* Heading deviation per aircraft (wind paper eq. 2), as a function of the *measured*
  heading z: d(z) = A + B sin z + C cos z [+ D sin 2z + E cos 2z] with A ~ U(-3, 3) deg,
  (B, C) of amplitude U(0.5, 3) deg at a random phase. z is the measured TRUE heading:
  no declination anywhere (the table has no magnetic heading or declination column,
  and aerotruth's diagnose fits its model on the true heading). The measured heading
  solves psi_m = psi_true + d(psi_m) + pitch_deg_per_deg x pitch (fixed point), then
  white noise `heading_noise_deg` per report.
* Hidden effects: `soft_iron_deg`: D, E of that amplitude at a random phase per aircraft
  (from its own random stream: the flights and noise are the same for every value);
  `pitch_deg_per_deg`: heading error k x pitch, pitch = flight-path angle through the
  air (atan(climb rate / TAS)) + angle of attack alpha = 2 deg x q_cruise / q,
  q = sigma(h) TAS^2 (sigma the ISA density ratio, q_cruise the leg's cruise value: each
  leg cruises at one lift coefficient); with `alpha_shape="weight"`, every leg at one
  weight instead: alpha = 2 deg x q_1 / q, q_1 that of 265 kt at 19,000 ft.
* `accel_error_deg`: a pendulous flux valve's acceleration error, heading error
  k x tan(I) x (dTAS/dt) / g x sin(psi_true - D) deg, with the generator's own centred
  dipole field (geomagnetic north pole 80.1N 72.2W, the IGRF 2010 dipole: tan I = 2 tan of
  the magnetic latitude, D the bearing to the pole; ~6 deg east and tan I 2.8 at the
  network's centre) and the leg's TAS rate (0 in cruise, +-0.4 cruise TAS over the climb).
* Each report (every U(3, 7) min from the top of the 2000-ft point): the onboard
  (TAMDAR) wind V_W = V_G(GPS, + 0.1 m/s white noise per component) - TAS_m (sin psi_m,
  cos psi_m) (wind paper eq. 1) with TAS_m = TAS + 0.5 kt white noise; reported as
  speed (kt, rounded to 1) and direction where it blows from (deg true, rounded to 1),
  lat/lon rounded to 0.01 deg, pressure altitude to 10 ft, time to 1 s (UTC epoch
  seconds, August 2009), heading (measured true, deg, 0.01) and TAS (kt, 0.1).
* Two reference models, `rr` and `rtfdda`: truth wind + white noise `ref_noise_ms` per
  component, independent between rows and models; speed/direction rounded to 0.01.

Columns: aircraft, time, lat, lon, pressure_altitude_ft, wind_speed_kt, wind_dir_deg,
heading_deg, tas_kt, phase, ref_source, ref_wind_speed_kt, ref_wind_dir_deg (one row per
report and model, sorted by aircraft, time, model). Flights are not labelled (no `flight`
column): legs are separated by >= 40 min on the ground (the reader's 30-min rule).

    >>> from straight_obs_generator import generate
    >>> df = generate(0)                                      # ~2 s
    >>> len(df), df.groupby(["aircraft", "time"]).ngroups     # rows, reports
    (22160, 11080)
    >>> from aerotruth.analysis.diagnose.wind import prepare
    >>> d = prepare(df)
    >>> d.table["row_gates"]                                  # 'used': rows that pass the gates
    {'used': 16074, 'speed_change': 3224, 'no_neighbours': 2862}
"""

from __future__ import annotations

import numpy as np
import pandas as pd

KT = 1852.0 / 3600.0  # m/s per kt
FT = 0.3048  # m per ft
A_WGS, E2_WGS = 6378137.0, 0.00669437999014
R_SPHERE = 6371008.8
CENTER = (45.0, -93.0)  # lat, lon
T_START = 1_249_862_400.0  # 2009-08-10T00:00Z
MODELS = ("rr", "rtfdda")
CLIMB_FPS = 1500.0 / 60.0  # ft/s
LOW_FT = 2000.0
ALPHA_CRUISE_DEG = 2.0
DT = 10.0  # s, integration grid
G = 9.80665  # m/s^2
POLE = (80.1, -72.2)  # geomagnetic north pole of the IGRF 2010 dipole, deg


def _dipole(lat, lon) -> tuple[np.ndarray, np.ndarray]:
    """(declination rad, tan of the dip) of a centred dipole at (lat, lon) deg."""
    f, lam = np.radians(lat), np.radians(lon)
    fp, lp = np.radians(POLE[0]), np.radians(POLE[1])
    sin_m = np.sin(f) * np.sin(fp) + np.cos(f) * np.cos(fp) * np.cos(lam - lp)
    decl = np.arctan2(np.cos(fp) * np.sin(lp - lam), np.cos(f) * np.sin(fp) - np.sin(f) * np.cos(fp) * np.cos(lp - lam))
    return decl, 2.0 * np.tan(np.arcsin(sin_m))


def _sigma(alt_ft):
    """ISA density ratio (troposphere)."""
    return (1.0 - 6.87559e-6 * np.asarray(alt_ft)) ** 4.25588


Q_ONE_WEIGHT = float(_sigma(19000.0)) * (265.0 * KT) ** 2  # sigma TAS^2 where one weight's alpha is 2 deg


class _Wind:
    """Smooth truth wind field: westerly growing with height + travelling non-divergent waves."""

    def __init__(self, rng: np.random.Generator, n_modes: int = 4):
        lam = rng.uniform(1.5e6, 4.0e6, n_modes)
        ang = rng.uniform(0, 2 * np.pi, n_modes)
        k = 2 * np.pi / lam
        self.kx, self.ky = k * np.sin(ang), k * np.cos(ang)
        self.omega = 2 * np.pi / (rng.uniform(1.5, 5.0, n_modes) * 86400.0) * rng.choice([-1, 1], n_modes)
        self.amp = rng.uniform(2.0, 6.0, n_modes) / k  # stream-function amplitude: velocity amp / k
        self.phase = rng.uniform(0, 2 * np.pi, n_modes)

    def __call__(self, lat, lon, alt_ft, t) -> tuple[np.ndarray, np.ndarray]:
        """(east, north) towards-components, m/s."""
        x = R_SPHERE * np.radians(np.asarray(lon) - CENTER[1]) * np.cos(np.radians(CENTER[0]))
        y = R_SPHERE * np.radians(np.asarray(lat) - CENTER[0])
        h = np.clip(np.asarray(alt_ft) / 24000.0, 0.0, 1.2)
        arg = (
            x[..., None] * self.kx + y[..., None] * self.ky - np.asarray(t)[..., None] * self.omega + self.phase
        )  # psi = sum amp cos(arg); u = -dpsi/dy, v = dpsi/dx
        s = self.amp * np.sin(arg)
        u = (s * self.ky).sum(-1)
        v = -(s * self.kx).sum(-1)
        grow = 1.0 + 0.5 * h
        return 10.0 + 30.0 * np.minimum(h, 1.0) + grow * u, grow * v


def _radii(lat_deg):
    s2 = np.sin(np.radians(lat_deg)) ** 2
    w = np.sqrt(1.0 - E2_WGS * s2)
    return A_WGS * (1.0 - E2_WGS) / w**3, A_WGS / w  # meridian M, prime vertical N


def _rhumb(p, q) -> tuple[float, float]:
    """Course (rad, true) and distance (m) of the rhumb line p -> q on a sphere."""
    f1, f2 = np.radians(p[0]), np.radians(q[0])
    dl = np.radians((q[1] - p[1] + 180.0) % 360.0 - 180.0)
    dpsi = np.log(np.tan(np.pi / 4 + f2 / 2) / np.tan(np.pi / 4 + f1 / 2))
    c = np.arctan2(dl, dpsi)
    qq = (f2 - f1) / dpsi if abs(dpsi) > 1e-12 else np.cos(f1)
    return float(c), float(R_SPHERE * np.hypot(f2 - f1, qq * dl))


def _profile(t, total, cruise_ft, tas_c):
    """Altitude (ft), TAS (m/s) and climb rate (ft/s) at times t of a leg lasting `total` s."""
    up, down = LOW_FT + CLIMB_FPS * t, LOW_FT + CLIMB_FPS * (total - t)
    alt = np.minimum(np.minimum(up, down), cruise_ft)
    rate = np.where(alt == cruise_ft, 0.0, np.where(up <= down, CLIMB_FPS, -CLIMB_FPS))
    tas = tas_c * (0.6 + 0.4 * (alt - LOW_FT) / (cruise_ft - LOW_FT))
    return alt, tas, rate


def _integrate(start, course, s):
    """lat, lon (deg) after the along-track distances s (m) on the constant course (WGS-84)."""
    lat = start[0] + np.degrees(s * np.cos(course) / _radii(start[0])[0])
    for _ in range(2):  # d lat / ds = cos c / M(lat), d lon / ds = sin c / (N(lat) cos lat)
        m, n = _radii(lat)
        ds = np.diff(s, prepend=0.0)
        lat = start[0] + np.degrees(np.cumsum(ds * np.cos(course) / m))
        lon = start[1] + np.degrees(np.cumsum(ds * np.sin(course) / (n * np.cos(np.radians(lat)))))
    return lat, lon


def _ground_speed(course, tas, we, wn):
    along = we * np.sin(course) + wn * np.cos(course)
    perp = we * np.cos(course) - wn * np.sin(course)
    return along + np.sqrt(np.maximum(tas**2 - perp**2, 1.0))


def _leg(start, end, t0, cruise_ft, tas_c, wind: _Wind, rng: np.random.Generator) -> dict:
    """One leg's reports (truth at each report time)."""
    course, dist = _rhumb(start, end)
    t_climb = (cruise_ft - LOW_FT) / CLIMB_FPS
    total = dist / (0.9 * tas_c) + 0.2 * t_climb
    # first guess of the positions: straight from start to end in proportion to time
    frac = np.linspace(0.0, 1.0, 101)
    lat, lon = start[0] + frac * (end[0] - start[0]), start[1] + frac * (end[1] - start[1])
    t_prev, total_prev = frac * total, total
    for _ in range(4):  # the leg's duration until the integrated distance is the route's
        t = np.arange(0.0, total + DT, DT)
        alt, tas, _ = _profile(t, total, cruise_ft, tas_c)
        # the winds where the previous pass put the aircraft at the same fraction of the leg
        lat, lon = np.interp(t / total, t_prev / total_prev, lat), np.interp(t / total, t_prev / total_prev, lon)
        we, wn = wind(lat, lon, alt, t0 + t)
        gs = _ground_speed(course, tas, we, wn)
        s = np.concatenate([[0.0], np.cumsum(0.5 * (gs[1:] + gs[:-1]) * DT)])
        lat, lon = _integrate(start, course, s)
        t_prev, total_prev = t, total
        total += (dist - s[-1]) / np.median(gs)  # a longer leg: a longer cruise
    # reports: every U(3, 7) min from the first, U(1, 4) min after leaving 2000 ft
    tr = rng.uniform(60.0, 240.0) + np.concatenate(
        [[0.0], np.cumsum(rng.uniform(180.0, 420.0, int(total / 180.0) + 2))]
    )
    tr = np.round(tr[tr < t_prev[-1] - 30.0])
    rlat, rlon = np.interp(tr, t_prev, lat), np.interp(tr, t_prev, lon)
    alt, tas, rate = _profile(tr, total_prev, cruise_ft, tas_c)
    we, wn = wind(rlat, rlon, alt, t0 + tr)
    gs = _ground_speed(course, tas, we, wn)
    vge, vgn = gs * np.sin(course), gs * np.cos(course)
    psi_t = np.degrees(np.arctan2(vge - we, vgn - wn))
    q = _sigma(alt) * tas**2
    alpha = ALPHA_CRUISE_DEG * _sigma(cruise_ft) * tas_c**2 / q
    gamma = np.degrees(np.arctan2(rate * FT, tas))
    tas_rate = np.sign(rate) * tas_c * 0.4 * CLIMB_FPS / (cruise_ft - LOW_FT)  # d/dt of _profile's TAS
    return dict(
        time=t0 + tr,
        lat=rlat,
        lon=rlon,
        alt=alt,
        tas=tas,
        we=we,
        wn=wn,
        vge=vge,
        vgn=vgn,
        psi_t=psi_t,
        gamma=gamma,
        tas_rate=tas_rate,
        alpha_cruise=alpha,
        alpha_weight=ALPHA_CRUISE_DEG * Q_ONE_WEIGHT / q,
        phase=np.where(rate > 0, "ascent", np.where(rate < 0, "descent", "level")),
        end_t=t0 + t_prev[-1],
        end=(float(lat[-1]), float(lon[-1])),
    )


def _from(e, n):
    """Speed (kt) and direction the wind blows from (deg) of towards-components (m/s)."""
    return np.hypot(e, n) / KT, np.degrees(np.arctan2(-e, -n)) % 360.0


def generate(
    seed: int,
    *,
    aircraft: int = 12,
    days: float = 8.0,
    soft_iron_deg: float = 0.0,
    pitch_deg_per_deg: float = 0.0,
    alpha_shape: str = "cruise",
    accel_error_deg: float = 0.0,
    heading_noise_deg: float = 0.3,
    ref_noise_ms: float = 2.2,
) -> pd.DataFrame:
    """The observation table (module docstring). Each part draws from its own random
    stream, so for one seed the flights, truth deviations and noise are the same
    whatever the hidden effects' sizes."""
    ss = np.random.SeedSequence([20240901, seed])
    r_plan, r_wind, r_fleet, r_soft, r_noise, r_ref = (np.random.default_rng(s) for s in ss.spawn(6))
    wind = _Wind(r_wind)
    cities = np.column_stack([CENTER[0] + r_plan.uniform(-4.5, 4.5, 14), CENTER[1] + r_plan.uniform(-6.0, 6.0, 14)])
    names = [f"N{501 + i}SX" for i in range(aircraft)]
    amp, ph = r_fleet.uniform(0.5, 3.0, aircraft), r_fleet.uniform(0, 2 * np.pi, aircraft)
    A, B, C = r_fleet.uniform(-3.0, 3.0, aircraft), amp * np.cos(ph), amp * np.sin(ph)
    tas_cruise = r_fleet.uniform(240.0, 290.0, aircraft) * KT
    ph2 = r_soft.uniform(0, 2 * np.pi, aircraft)
    D, E = soft_iron_deg * np.cos(ph2), soft_iron_deg * np.sin(ph2)
    t_end = T_START + days * 86400.0
    parts = []
    for i in range(aircraft):
        city = int(r_plan.integers(len(cities)))
        pos = tuple(cities[city])
        day = 0
        t = T_START + 10 * 3600.0 + r_plan.uniform(0, 3600.0)
        while t < t_end:
            while True:  # a destination 200-1000 km away
                nxt = int(r_plan.integers(len(cities)))
                dist = _rhumb(pos, cities[nxt])[1]
                if nxt != city and 2e5 <= dist <= 1e6:
                    break
            leg = _leg(pos, tuple(cities[nxt]), t, r_plan.uniform(14000.0, 24000.0), tas_cruise[i], wind, r_plan)
            leg["aircraft"] = np.full(len(leg["time"]), i)
            parts.append(leg)
            city, pos = nxt, leg["end"]
            t = leg["end_t"] + r_plan.uniform(40 * 60.0, 100 * 60.0)
            if t > T_START + day * 86400.0 + 28 * 3600.0:  # after 04:00 UTC: overnight
                day += 1
                t = T_START + day * 86400.0 + 10 * 3600.0 + r_plan.uniform(0, 3600.0)
    rep = {k: np.concatenate([p[k] for p in parts]) for k in parts[0] if k not in ("end_t", "end")}
    keep = rep["time"] < t_end
    rep = {k: v[keep] for k, v in rep.items()}
    n = len(rep["time"])
    ac = rep["aircraft"]
    alpha = {"cruise": rep["alpha_cruise"], "weight": rep["alpha_weight"]}[alpha_shape]
    extra = pitch_deg_per_deg * (rep["gamma"] + alpha)
    if accel_error_deg:
        decl, tan_i = _dipole(rep["lat"], rep["lon"])
        extra = extra + accel_error_deg * tan_i * rep["tas_rate"] / G * np.sin(np.radians(rep["psi_t"]) - decl)
    psi = rep["psi_t"] + extra
    for _ in range(6):  # psi_m = psi_true + d(psi_m) + extra
        z = np.radians(psi)
        d = A[ac] + B[ac] * np.sin(z) + C[ac] * np.cos(z) + D[ac] * np.sin(2 * z) + E[ac] * np.cos(2 * z)
        psi = rep["psi_t"] + d + extra
    psi_m = (psi + r_noise.normal(0.0, heading_noise_deg, n)) % 360.0
    tas_m = rep["tas"] + r_noise.normal(0.0, 0.5 * KT, n)
    gps = r_noise.normal(0.0, 0.1, (2, n))
    w_e = rep["vge"] + gps[0] - tas_m * np.sin(np.radians(psi_m))  # wind paper eq. 1, onboard
    w_n = rep["vgn"] + gps[1] - tas_m * np.cos(np.radians(psi_m))
    spd, drc = _from(w_e, w_n)
    base = pd.DataFrame(
        {
            "aircraft": np.array(names, dtype=object)[ac],
            "time": rep["time"],
            "lat": np.round(rep["lat"], 2),
            "lon": np.round(rep["lon"], 2),
            "pressure_altitude_ft": np.round(rep["alt"], -1),
            "wind_speed_kt": np.round(spd),
            "wind_dir_deg": np.round(drc) % 360.0,
            "heading_deg": np.round(psi_m, 2) % 360.0,
            "tas_kt": np.round(tas_m / KT, 1),
            "phase": rep["phase"],
        }
    )
    out = []
    for m in MODELS:
        err = r_ref.normal(0.0, ref_noise_ms, (2, n))
        rs, rd = _from(rep["we"] + err[0], rep["wn"] + err[1])
        out.append(base.assign(ref_source=m, ref_wind_speed_kt=np.round(rs, 2), ref_wind_dir_deg=np.round(rd, 2)))
    df = pd.concat(out, ignore_index=True)
    return df.sort_values(["aircraft", "time", "ref_source"], kind="stable", ignore_index=True)


def truth(seed: int, *, aircraft: int = 12, soft_iron_deg: float = 0.0) -> pd.DataFrame:
    """The hidden deviation coefficients (deg) and cruise TAS (kt) of `generate(seed, ...)`."""
    ss = np.random.SeedSequence([20240901, seed])
    _, _, r_fleet, r_soft, _, _ = (np.random.default_rng(s) for s in ss.spawn(6))
    amp, ph = r_fleet.uniform(0.5, 3.0, aircraft), r_fleet.uniform(0, 2 * np.pi, aircraft)
    A = r_fleet.uniform(-3.0, 3.0, aircraft)
    tas = r_fleet.uniform(240.0, 290.0, aircraft)
    ph2 = r_soft.uniform(0, 2 * np.pi, aircraft)
    return pd.DataFrame(
        {
            "A": A,
            "B": amp * np.cos(ph),
            "C": amp * np.sin(ph),
            "D": soft_iron_deg * np.cos(ph2),
            "E": soft_iron_deg * np.sin(ph2),
            "cruise_tas_kt": tas,
        },
        index=pd.Index([f"N{501 + i}SX" for i in range(aircraft)], name="aircraft"),
    )
