"""The smallest campaign that runs: one wind-climatology task (no JSBSim), a second or two.
Shared by the tests that break campaign files and runs on purpose."""

TINY_CAMPAIGN = """\
name: tiny1
seed: 3
periods:
  - name: p
    dates: [2009-08-15]
studies:
  wind_climatology:
    regions:
      - {name: box, lat_deg: [44, 46], lon_deg: [-94, -92]}
    periods: [p]
    flight_levels: [100]
    hours_utc: [0]
    points: 20
"""
