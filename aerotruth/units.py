"""Unit constants: SI inside, these conversions only at the edges (config, reports, files).

Exact definitions: 1 ft = 0.3048 m (international foot), 1 nmi = 1852 m, 1 kt = 1852/3600 m/s.
"""

from math import pi

FT = 0.3048  # m per ft
NM = 1852.0  # m per nautical mile
KT = 1852.0 / 3600.0  # m/s per knot
FPM = FT / 60.0  # m/s per ft/min
DEG = pi / 180.0  # rad per degree
HPA = 100.0  # Pa per hPa
LBF = 4.4482216152605  # N per lbf
SLUG_FT2 = 1.3558179483314  # kg m^2 per slug ft^2
KG_PER_LB = 0.45359237
G0 = 9.80665  # m/s^2, standard gravity
EARTH_RADIUS_M = 6371008.8  # mean Earth radius (IUGG), for spherical great-circle approximations
