"""`aerotruth reports TRAFFIC --reference consensus --out OBS.parquet`: multi-aircraft traffic
(a decoded Mode-S / ADS-B state table, aerotruth.measured.traffic) to the observation table
that `heading fit`, `heading apply` and `diagnose` read (docs/data-formats.md), with the
consensus of the other aircraft as the reference wind (aerotruth.analysis.wind.consensus).

Writes OBS (.parquet, .csv or .csv.gz, by its name) and prints one line: samples read, left
out (incomplete rows, no reference), aircraft, and the consensus groups.
"""

from __future__ import annotations

from pathlib import Path

from aerotruth.analysis.wind.consensus import (
    CONSENSUS_LAYER_FT,
    CONSENSUS_RADIUS_KM,
    CONSENSUS_WINDOW_S,
    observation_table,
)
from aerotruth.errors import DataError, UserError
from aerotruth.files import atomic_write, atomic_write_text
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
) -> int:
    """Run the command (module docstring); bad input raises a UserError in one line."""
    out = Path(out_path)
    kind = table_kind(out)
    if kind is None:
        raise UserError(f"--out: {out}: expected a .parquet, .csv or .csv.gz file name")
    if out.is_dir() or not out.parent.is_dir():
        raise UserError(f"--out: {out}: expected a file name in an existing folder")
    if reference not in REFERENCES:
        raise UserError(f"--reference: expected one of {', '.join(REFERENCES)}, got {reference!r}")
    try:
        traffic = read_traffic(traffic_path)
    except DataError as e:
        raise UserError(str(e)) from None
    obs = observation_table(traffic, radius_km=radius_km, layer_ft=layer_ft, window_s=window_s)
    if len(obs) == 0:
        raise UserError(
            f"{traffic_path}: no sample has another aircraft within {radius_km:g} km, {layer_ft:g} ft and "
            f"{window_s:g} s (--radius-km, --layer-ft, --window-s): a consensus needs traffic around each aircraft"
        )
    table = obs.copy()
    table.attrs = {}  # the run's counts and consensus table are said, not stored in the file
    if kind == "parquet":
        atomic_write(out, lambda tmp: table.to_parquet(tmp, index=False))
    elif out.name.lower().endswith(".gz"):
        atomic_write(out, lambda tmp: table.to_csv(tmp, index=False, compression="gzip"))
    else:
        atomic_write_text(out, table.to_csv(index=False))
    groups = obs.attrs["consensus_aircraft"]
    seen = groups[groups["seen"]]
    print(
        f"{traffic_path}: {traffic.attrs['rows_read']} rows, {traffic.attrs['rows_incomplete']} incomplete, "
        f"{obs.attrs['without_reference']} without another aircraft near; {len(obs)} reports of "
        f"{obs['aircraft'].nunique()} aircraft in {seen['group'].nunique()} consensus group(s) -> {out}"
    )
    return 0
