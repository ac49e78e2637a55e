"""Aircraft types (aerotruth.truth.aircraft_types): the angle of attack of the lift
equation, the types by ICAO designator, and which type a Mode-S flight is diagnosed with
(aerotruth.measured.modes.aircraft_of: the flag over the data, the data over the speed)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from aerotruth.errors import DataError, UserError
from aerotruth.measured.kinds import Measured
from aerotruth.measured.modes import aircraft_of
from aerotruth.truth.aircraft_types import (
    A310,
    GENERIC_JET,
    GENERIC_TURBOPROP,
    SAAB340,
    aircraft_type,
    engine_class,
)


def test_the_generic_jets_alpha_is_the_lift_equation_worked_by_hand():
    """The generic jet (123.6 m2, 71,000 kg, A 9.5, half-chord sweep 22 deg, alpha_0 -2 deg)
    at FL300 ISA, Mach 0.78, wings level:

    * ISA at 9,144 m: T = 288.15 - 0.0065 x 9144 = 228.71 K, p = 30,090 Pa,
      rho = 30090 / (287.053 x 228.71) = 0.4583 kg/m3, a = sqrt(1.4 x 287.053 x 228.71)
      = 303.18 m/s; V = 0.78 a = 236.48 m/s; q = rho V^2 / 2 = 12,815 Pa;
    * CL = W / (q S) = 71000 x 9.80665 / (12815 x 123.6) = 0.4396;
    * lift slope (Helmbold-DATCOM): beta^2 = 1 - 0.78^2 = 0.3916, (A / 0.95)^2 = 100,
      tan^2 22 deg = 0.1632: sqrt(4 + 100 (0.3916 + 0.1632)) = 7.713,
      2 pi 9.5 / (2 + 7.713) = 6.146, x 0.98 = 6.023 per rad;
    * W = q S CL_alpha (alpha - alpha_0): alpha - alpha_0 = 0.4396 / 6.023 = 0.07299 rad
      = 4.182 deg, alpha = 2.18 deg; banked 30 deg, n = 1.1547: alpha = -2 + 4.829 = 2.83 deg."""
    v = 0.78 * math.sqrt(1.4 * 287.05287 * 228.714)
    assert GENERIC_JET.lift_slope_per_rad(0.78) == pytest.approx(6.023, abs=0.002)
    assert GENERIC_JET.alpha_deg(v, 9144.0) == pytest.approx(2.18, abs=0.01)
    assert GENERIC_JET.alpha_deg(v, 9144.0, math.radians(30.0)) == pytest.approx(2.83, abs=0.01)


def test_the_saab_340_keeps_the_law_fitted_on_its_truth_flights():
    """alpha = -3.40 deg + 30352 Pa deg / (q cos roll), q at the ISA density of the pressure
    altitude: at 3,000 m (rho 0.9091 kg/m3) and 120 m/s, q = 6,546 Pa, alpha = 1.237 deg."""
    assert SAAB340.alpha_deg(120.0, 3000.0) == pytest.approx(-3.40 + 30352.0 / 6546.0, abs=0.002)
    assert SAAB340.alpha_deg(120.0, 3000.0, 0.3) == pytest.approx(-3.40 + 30352.0 / (6546.0 * math.cos(0.3)), abs=0.002)


def test_types_by_designator_generic_classes_by_engine_and_one_line_for_the_unknown():
    assert aircraft_type("a310")[0] is A310
    assert aircraft_type("jet")[0] is GENERIC_JET
    t, note = aircraft_type("B77W", "L2J")
    assert t is GENERIC_JET and "B77W is not listed" in note
    assert aircraft_type("DH8D", "turboprop")[0] is GENERIC_TURBOPROP
    assert (engine_class("L2T"), engine_class("turbofan"), engine_class("electric")) == ("turboprop", "jet", None)
    with pytest.raises(UserError) as e:
        aircraft_type("B77W", what="--aircraft-type")
    msg = str(e.value)
    assert msg.startswith("--aircraft-type 'B77W' is not known; known types: SF34, A310") and "\n" not in msg
    with pytest.raises(UserError, match="engine type 'electric' is neither jet nor turboprop"):
        aircraft_type("B77W", "electric")


def _flight(mach: float, **fields) -> tuple[Measured, pd.DataFrame]:
    n = 50
    df = pd.DataFrame(
        {
            "time_s": 1.6e9 + np.arange(n, dtype=float),
            "altitude": 30000.0,
            "TAS": mach * 589.3,  # kt: the ISA speed of sound at FL300 is 589.3 kt
            **fields,
        }
    )
    return Measured("modes_track", df, "f.json"), df


def test_the_type_is_the_flags_over_the_datas_and_the_datas_over_the_speed():
    m, d = _flight(0.78, typecode="B738")
    t, note = aircraft_of(m, d, "A310")
    assert t is A310 and note == "A310, Airbus A310-300 (given; the data's typecode says B738)"
    t, note = aircraft_of(m, d)
    assert t.designator == "B738" and note.endswith("(the data's typecode)")
    # no type: a jet by its speed, else the simulation's own turboprop
    assert aircraft_of(*_flight(0.78))[0] is GENERIC_JET
    assert aircraft_of(*_flight(0.45))[0] is SAAB340
    assert aircraft_of(*_flight(0.45, engine_type="L2J"))[0] is GENERIC_JET
    with pytest.raises(DataError, match=r"f\.json: field 'typecode' names 2 values \(A310, B738\)"):
        m, d = _flight(0.78, typecode=["B738"] * 25 + ["A310"] * 25)
        aircraft_of(m, d)
    with pytest.raises(UserError, match=r"f\.json: field 'typecode': aircraft type 'ZZZZ' is not known"):
        aircraft_of(*_flight(0.78, typecode="ZZZZ"))
