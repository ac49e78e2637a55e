"""`aerotruth reports TRAFFIC --reference consensus|FILE --out OBS.parquet`: multi-aircraft
traffic (a decoded Mode-S / ADS-B state table, aerotruth.measured.traffic) to the observation
table that `heading fit`, `heading apply` and `diagnose` read (docs/data-formats.md). The
reference wind is either the consensus of the other aircraft (`consensus`,
aerotruth.analysis.wind.consensus) or a gridded weather analysis, a NetCDF or GRIB file such
as ERA5 on pressure levels (aerotruth.measured.gridded), interpolated to each report
(aerotruth.analysis.wind.gridded_reference); its `ref_source` is the file's stem.

Samples banked over 10 deg (the table's roll, else the bank of a coordinated turn at the
ADS-B track's rate over +-10 s; consensus.implied_bank_deg) are left out, as the wind paper
drops banked reports: in turns the BDS 6,0 heading and the ADS-B velocity, sampled at
different instants, disagree by the turn rate times the time between them.

Writes OBS (.parquet, .csv or .csv.gz, by its name) and prints one line: samples read, left
out (incomplete rows, banked, no reference and why), aircraft, and the consensus groups or
the analysis's span.
"""

from __future__ import annotations

from pathlib import Path

from aerotruth.analysis.wind.consensus import (
    CONSENSUS_LAYER_FT,
    CONSENSUS_RADIUS_KM,
    CONSENSUS_WINDOW_S,
    MAX_BANK_DEG,
    observation_table,
    straight_samples,
)
from aerotruth.analysis.wind.gridded_reference import gridded_observation_table, report_positions
from aerotruth.errors import DataError, UserError, output_file
from aerotruth.files import atomic_write, atomic_write_text
from aerotruth.measured.gridded import read_wind_grid
from aerotruth.measured.observations import table_kind
from aerotruth.measured.traffic import read_traffic

REFERENCES = ("consensus",)


def reports_main(
    traffic_path: str,
    out_path: str,
    reference: str = "consensus",
    radius_km: float = CONSENSUS_RADIUS_KM,
    layer_ft: float = CONSENSUS_LAYER_FT,
    window_s: float = CONSENSUS_WINDOW_S,
    reference_name: str | None = None,
) -> int:
    """Run the command (module docstring); bad input raises a UserError in one line.
    `reference` is "consensus" or the path of a gridded analysis; `reference_name` labels a
    gridded reference's rows (`ref_source`; default the file's stem)."""
    out = Path(out_path)
    kind = table_kind(out)
    if kind is None:
        raise UserError(f"--out: {out}: expected a .parquet, .csv or .csv.gz file name")
    if out.is_dir() or not out.parent.is_dir():
        raise UserError(f"--out: {out}: expected a file name in an existing folder")
    output_file(out, "--out")  # writable, before the work
    if reference not in REFERENCES and not Path(reference).is_file():
        raise UserError(
            f"--reference: expected one of {', '.join(REFERENCES)}, got {reference!r}, which is not an existing file "
            "either (a gridded analysis: NetCDF, or GRIB)"
        )
    try:
        traffic = read_traffic(traffic_path)
    except DataError as e:
        raise UserError(str(e)) from None
    traffic = straight_samples(traffic)  # the wind paper's roll gate, from the track's turn where no roll
    if reference in REFERENCES:
        obs = observation_table(traffic, radius_km=radius_km, layer_ft=layer_ft, window_s=window_s)
        if len(obs) == 0:
            raise UserError(
                f"{traffic_path}: no sample has another aircraft within {radius_km:g} km, {layer_ft:g} ft and "
                f"{window_s:g} s (--radius-km, --layer-ft, --window-s): a consensus needs traffic around each aircraft"
            )
        groups = obs.attrs["consensus_aircraft"]
        seen = groups[groups["seen"]]
        said = (
            f"{obs.attrs['without_reference']} without another aircraft near; {len(obs)} reports of "
            f"{obs['aircraft'].nunique()} aircraft in {seen['group'].nunique()} consensus group(s)"
        )
    else:
        try:
            grid = read_wind_grid(reference, near=report_positions(traffic), name=reference_name)
        except DataError as e:
            raise UserError(f"--reference: {e}") from None
        obs = gridded_observation_table(traffic, grid)
        a = obs.attrs
        outside = (
            f"{a['outside_time']} outside its times, {a['outside_level']} outside its levels, "
            f"{a['outside_area']} outside its area, {a['missing_value']} at missing grid values"
        )
        if len(obs) == 0:
            raise UserError(
                f"{traffic_path}: no sample lies inside the analysis {reference} ({grid.span.describe()}): {outside}"
            )
        said = (
            f"{a['without_reference']} without a reference ({outside}); {len(obs)} reports of "
            f"{obs['aircraft'].nunique()} aircraft against {grid.name} ({grid.span.describe()})"
        )
    table = obs.copy()
    table.attrs = {}  # the run's counts and consensus table are said, not stored in the file
    if kind == "parquet":
        atomic_write(out, lambda tmp: table.to_parquet(tmp, index=False))
    elif out.name.lower().endswith(".gz"):
        atomic_write(out, lambda tmp: table.to_csv(tmp, index=False, compression="gzip"))
    else:
        atomic_write_text(out, table.to_csv(index=False))
    print(
        f"{traffic_path}: {traffic.attrs['rows_read']} rows, {traffic.attrs['rows_incomplete']} incomplete, "
        f"{traffic.attrs.get('rows_on_ground', 0)} on the ground, {traffic.attrs['turning']} banked over "
        f"{MAX_BANK_DEG:g} deg, "
        f"{said} -> {out}"
    )
    return 0


def observations_or_traffic_hint(path: str):
    """The observation table at `path` (aerotruth.measured.observations); where the file is not
    one but traffic this command could make one from, a DataError saying so (or naming what
    the traffic lacks), instead of the table reader's complaint about its name or columns."""
    from aerotruth.measured.observations import read_observation_table

    try:
        return read_observation_table(path)
    except DataError as not_table:
        try:
            traffic = read_traffic(path)
        except DataError as e:
            # a file named as a table keeps the table reader's word (a bad cell, a missing column);
            # another file that is traffic lacking something gets the traffic reader's
            if (
                table_kind(Path(path)) is not None
                or "not traffic aerotruth reads" in str(e)
                or "no such file" in str(e)
            ):
                raise not_table from None
            raise DataError(f"{e} (not an observation table either)") from None
        n = traffic["aircraft"].nunique()
        how = (
            "--reference consensus --out OBS.parquet` (or --reference ANALYSIS, a gridded analysis)"
            if n > 1
            else "--reference ANALYSIS --out OBS.parquet` with a gridded analysis (a consensus needs other aircraft)"
        )
        raise DataError(
            f"{path}: traffic of {n} aircraft, not an observation table: make one first with `aerotruth reports "
            f"{path} {how}"
        ) from None
