"""What a fleet fit needs besides the fits themselves: the check that some report passes the
ground-track gates, the flight-resampling bootstrap intervals of every aircraft's table,
and the warnings when an aircraft's `heading_deg` does not look like the true heading its
reported wind was computed with (a magnetic heading, or another offset)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from aerotruth.analysis.wind.heading_correction import FleetHeadingFit
from aerotruth.errors import DataError

# `heading_deg` is true heading. It only indexes the table (d comes from the winds, eqs.
# 3-4), so a magnetic one there (Mode-S BDS 6,0 heading is) turns the fitted sinusoid by the
# declination D and leaves A alone; but it differs from the heading of the report's own air
# vector (V_G - V_W,TAM, eq. 3: the aircraft's measured true heading, whatever its
# deviation) by -D. Said when that median difference is within MAGNETIC_SUSPECT_TOL_DEG of
# -D where |D| >= MAGNETIC_SUSPECT_MIN_DEG.
MAGNETIC_SUSPECT_TOL_DEG = 2.0


MAGNETIC_SUSPECT_MIN_DEG = 4.0


# any other median offset this large is said too (beyond HEADING_SUSPECT_DEG the table is
# refused, heading_errors._check_heading_column)
OFFSET_SUSPECT_DEG = 10.0


def magnetic_heading_warnings(obs: pd.DataFrame, rows: pd.DataFrame) -> list[str]:
    """One line per aircraft whose `heading_deg` sits about minus the IGRF declination (at the
    median place and time of its reports) from its reports' air-vector heading (it looks
    magnetic), or OFFSET_SUSPECT_DEG or more from it otherwise. `rows`: heading_errors of
    `obs`."""
    import datetime as dt

    from aerotruth.analysis.wind.modes_wind import declination_deg

    if "heading_deg" not in obs.columns:
        return []
    used = rows["gate"].to_numpy() == "used"
    r = rows.loc[used]
    psi = np.degrees(np.arctan2(r["va_e"].to_numpy(), r["va_n"].to_numpy()))
    diff = (
        pd.Series((r["heading_deg"].to_numpy() - psi + 180.0) % 360.0 - 180.0)
        .groupby(r["aircraft"].to_numpy())
        .median()
    )
    out = []
    ac = obs["aircraft"].to_numpy()
    for name, off in diff[diff.abs() >= MAGNETIC_SUSPECT_MIN_DEG - MAGNETIC_SUSPECT_TOL_DEG].items():  # IGRF only
        mine = obs.loc[ac == name]  # for those that could be magnetic (ppigrf reads its coefficients each call)
        when = dt.datetime(1970, 1, 1) + dt.timedelta(seconds=float(mine["time_s"].median()))
        d = float(
            declination_deg(
                mine["lat"].median(), mine["lon"].median(), mine["pressure_altitude_ft"].median() * 0.3048, when
            )[0]
        )
        if abs(d) >= MAGNETIC_SUSPECT_MIN_DEG and abs(off + d) <= MAGNETIC_SUSPECT_TOL_DEG:
            out.append(
                f"aircraft {name}: `heading_deg` is {off:+.1f} deg from the heading of its reports' air vector "
                f"(eq. 3), about minus the declination there ({d:+.1f} deg, IGRF): is it magnetic? It should be "
                "true heading (a magnetic heading goes in `heading_mag_deg`); as given, the table is indexed by "
                "magnetic heading"
            )
        elif abs(off) >= OFFSET_SUSPECT_DEG:
            out.append(
                f"aircraft {name}: `heading_deg` is {off:+.1f} deg from the heading of its reports' air vector "
                f"(eq. 3; the declination there {d:+.1f} deg, IGRF): is it the heading the reported wind was "
                f"computed with? As given, the table is indexed by it"
            )
    return out


def require_used_reports(rows: pd.DataFrame, source: str) -> None:
    """DataError when no report of `heading_errors` rows passes the gates (nothing to fit or score)."""
    if not (rows["gate"] == "used").any():
        raise DataError(
            f"{source}: no report passes the ground-track gates (three adjacent reports of one flight, "
            "collinear and at constant speed beyond what the 0.01-deg position step can fake, <= 10 min apart): "
            "columns 'time', 'lat', 'lon' may not be one aircraft's sequence"
        )


CI_COLUMNS = ("aircraft", "quantity", "estimate", "lo", "hi", "boot_se", "level", "n_boot", "method")


def bootstrap_table(fleet: FleetHeadingFit, n_boot: int, seed: int, level: float = 0.95) -> pd.DataFrame:
    """Flight-resampling bootstrap-t intervals (HeadingDeviationFit.bootstrap) of every
    fitted aircraft's coefficients and 8 table entries, one row per (aircraft, quantity);
    each aircraft its own stream of `seed`, so an aircraft's intervals do not depend on the
    others in the file."""
    parts = []
    for i, (name, fit) in enumerate(fleet.fits_.items()):
        if fit.status_ == "refused":
            continue
        ci = fit.bootstrap(n_boot=n_boot, rng=np.random.default_rng([seed, i]), level=level)
        parts.append(ci.rename_axis("quantity").reset_index().assign(aircraft=name, level=level, n_boot=n_boot))
    return pd.concat(parts, ignore_index=True)[list(CI_COLUMNS)] if parts else pd.DataFrame(columns=list(CI_COLUMNS))
