"""Open-loop acceptance of the SAAB 340B JSBSim model.

Every performance number comes from a fixed power lever; only the elevator (altitude,
speed or flight-path hold) and the ailerons (wings level) are closed loops, and only
where the criterion is a steady state. Expected ranges are published SAAB 340B
performance figures (Jane's-class specifications).

Measured with this model (`python -m pytest tests/test_saab340.py -q -s` prints them):
cruise 267.6 KTAS at FL150 and 256.7 KTAS at FL250 (12,000 kg, lever 0.85, 1,230 rpm);
climb 2,000 ft/min at MTOW, 160 KIAS, ~3,600 ft; rate of climb 268 ft/min at FL250 and
-64 ft/min at FL300 (service ceiling ~27,500 ft); approach 126.5 KIAS on 3 deg with
~550 shp per engine; clean stall 109.7 KCAS (CLmax 1.52) at 13,000 kg and 1.0 kt/s;
flaps 35 and gear down, idle, forward CG: Vs 83.6/87.3/92.6 KCAS at 10,500/11,500/12,930 kg
(CLmax 2.11), Vref 108.7/113.5/120.4 KCAS, pitch at Vref on 3 deg +1.0/+1.0/+0.9 deg;
Dutch roll damping ratio 0.13; spiral convergent at FL150 (doubling ~160 s at 170 KTAS
low down); 948 shp per engine available at FL250. Step cost against the 737 is a
benchmark line (benchmarks/truth_speed.py `saab340_vs_737_step_ratio`), not a timed test.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest
import saab340_checks as chk

from aerotruth.units import DEG, FPM, FT, KG_PER_LB, KT, SLUG_FT2

HP = chk.HP_W


def _report(label: str, value: float) -> None:
    print(f"{label}: {value:.2f}")


@pytest.mark.slow
def test_model_loads_from_the_package_layout_with_published_geometry_and_mass():
    fdm = chk.load_saab340()
    chk.start_airborne(fdm, 10000.0 * FT, tas_ms=220.0 * KT, mass_kg=chk.MTOW_KG, fuel_kg=chk.FUEL_CAPACITY_KG)
    assert fdm.get_model_name() == "saab340"
    assert fdm["metrics/Sw-sqft"] == pytest.approx(450.0, rel=1e-3)  # 41.81 m2
    assert fdm["metrics/bw-ft"] * FT == pytest.approx(21.44, rel=1e-3)
    assert fdm["inertia/empty-weight-lbs"] * KG_PER_LB == pytest.approx(8140.0, rel=1e-3)
    assert fdm["inertia/weight-lbs"] * KG_PER_LB == pytest.approx(chk.MTOW_KG, rel=1e-3)
    fuel = sum(fdm[f"propulsion/tank[{i}]/contents-lbs"] for i in (0, 1)) * KG_PER_LB
    assert fuel == pytest.approx(2580.0, rel=1e-3)
    # Roskam radii of gyration 0.25 / 0.38 / 0.39 at MTOW (R part V table 4.1):
    # I = m (R b/2)^2 with b = span (Ixx, Izz) or length 19.73 m (Iyy)
    m = chk.MTOW_KG
    expected = {
        "ixx": m * (0.25 * 21.44 / 2) ** 2,
        "iyy": m * (0.38 * 19.73 / 2) ** 2,
        "izz": m * (0.39 * (21.44 + 19.73) / 4) ** 2,
    }
    for axis, value in expected.items():
        assert fdm[f"inertia/{axis}-slugs_ft2"] * SLUG_FT2 == pytest.approx(value, rel=0.05), axis
    # CG within the usual forward/aft range of the MAC (LEMAC 8.10 m, MAC 2.02 m)
    cg_mac = (fdm["inertia/cg-x-in"] * 0.0254 - 8.10) / 2.02
    assert 0.15 < cg_mac < 0.35


@pytest.mark.slow
def test_flap_detents_and_gear_follow_their_commands_at_their_rates():
    fdm = chk.load_saab340()
    chk.start_airborne(fdm, 5000.0 * FT, cas_ms=160.0 * KT, gear_down=True, throttle=0.5)
    assert fdm["gear/gear-pos-norm"] == 1.0 and fdm["fcs/flap-pos-deg"] == 0.0
    fdm["fcs/flap-cmd-norm"] = 15.0 / 35.0  # a detent: deg / 35
    fdm["fcs/gear-cmd-norm"] = 0.0
    for _ in range(400):  # 4 s: flaps run 35 deg in 14 s, gear 0..1 in 8 s
        fdm.run()
    assert fdm["fcs/flap-pos-deg"] == pytest.approx(4.0 * 35.0 / 14.0, abs=0.1)
    assert fdm["gear/gear-pos-norm"] == pytest.approx(0.5, abs=0.02)
    for _ in range(600):
        fdm.run()
    assert fdm["fcs/flap-pos-deg"] == pytest.approx(15.0, abs=1e-6)
    assert fdm["gear/gear-pos-norm"] == pytest.approx(0.0, abs=1e-6)
    assert fdm["aero/coefficient/CDgear"] == pytest.approx(0.0, abs=1e-9)
    # control sign conventions of the shipped JSBSim models
    fdm["fcs/elevator-cmd-norm"] = 1.0
    fdm["fcs/aileron-cmd-norm"] = 1.0
    fdm["fcs/rudder-cmd-norm"] = 1.0
    fdm.run()
    assert fdm["aero/coefficient/Cmde"] < 0.0  # nose down
    assert fdm["aero/coefficient/Clda"] > 0.0  # roll right
    assert fdm["aero/coefficient/Cndr"] < 0.0  # nose left


@pytest.mark.slow
def test_engine_is_flat_rated_near_sea_level_and_lapses_to_900_1000_shp_at_fl250():
    power = {}
    for alt_ft in (0.0, 25000.0):
        fdm = chk.load_saab340()
        altitude = max(alt_ft * FT, 300.0)  # "sea level": 1,000 ft, clear of the ground
        chk.start_airborne(fdm, altitude, tas_ms=180.0 * KT, throttle=1.0, advance=1.0)
        holds = chk.Holds(fdm, "altitude", altitude)
        for _ in range(1500):
            holds.step()
            fdm.run()
        assert abs(fdm["position/h-sl-ft"] * FT - altitude) < 30.0
        power[alt_ft] = fdm["propulsion/engine/power-hp"]
        ff_lbh = fdm["propulsion/engine/fuel-flow-rate-pps"] * 3600.0
        if alt_ft == 0.0:
            sfc = ff_lbh / power[alt_ft]
            assert 0.46 < sfc < 0.52  # lb/shp/h at full power (CT7 class)
        assert fdm["propulsion/engine/propeller-rpm"] == pytest.approx(1384.0, abs=10.0)
    _report("shp sea level", power[0.0])
    _report("shp FL250", power[25000.0])
    assert power[0.0] == pytest.approx(1750.0, abs=5.0)  # flat rating holds at 1,000 ft
    assert 900.0 < power[25000.0] < 1000.0


@pytest.mark.slow
@pytest.mark.parametrize("altitude_ft, lo_kt, hi_kt", [(15000.0, 250.0, 282.0), (25000.0, 240.0, 270.0)])
def test_cruise_power_gives_the_published_true_airspeed(altitude_ft, lo_kt, hi_kt):
    r = chk.level_cruise(altitude_ft * FT, mass_kg=12000.0)
    _report(f"cruise KTAS FL{altitude_ft / 100:.0f}", r.tas_ms / KT)
    assert abs(r.tas_drift_ms2) < 0.01 * KT  # steady: < 0.01 kt/s left
    assert abs(r.altitude_m - altitude_ft * FT) < 5.0
    assert lo_kt <= r.tas_ms / KT <= hi_kt
    assert r.shaft_power_w < 1750.0 * HP


@pytest.mark.slow
def test_mtow_climb_at_maximum_continuous_power_exceeds_1500_fpm():
    r = chk.steady_climb(1000.0 * FT, 160.0 * KT, mass_kg=chk.MTOW_KG)
    _report("climb fpm MTOW", r.vertical_speed_ms / FPM)
    assert r.cas_ms / KT == pytest.approx(160.0, abs=2.0)
    assert r.altitude_m < 5000.0 * FT  # near sea level
    assert r.vertical_speed_ms / FPM >= 1500.0


@pytest.mark.slow
def test_service_ceiling_at_mtow_lies_between_fl250_and_fl300():
    roc250, roc300, ceiling = chk.service_ceiling(25000.0 * FT, 30000.0 * FT, 160.0 * KT)
    _report("ROC fpm FL250", roc250 / FPM)
    _report("ROC fpm FL300", roc300 / FPM)
    _report("service ceiling ft", ceiling / FT)
    assert roc250 / FPM > 100.0
    assert roc300 / FPM < 100.0


@pytest.mark.slow
def test_approach_flaps_35_gear_down_is_stable_on_3_degrees_at_115_135_kias():
    r = chk.approach(chk.APPROACH_THROTTLE)
    s = r.steady
    _report("approach KIAS", s.cas_ms / KT)
    _report("approach shp", s.shaft_power_w / HP)
    assert 115.0 <= s.cas_ms / KT <= 135.0
    assert r.cas_span_ms < 1.0 * KT  # speed steady over the last 40 s
    assert abs(s.tas_drift_ms2) < 0.02 * KT
    assert r.gamma_error_max_rad < 0.2 * DEG
    assert s.shaft_power_w < 0.6 * 1750.0 * HP  # well below maximum continuous


@pytest.mark.slow
@pytest.mark.parametrize("mass_kg", [10500.0, 11500.0, 12930.0])
def test_flaps_35_vref_and_approach_pitch_lie_in_the_published_bands(mass_kg):
    """1-g stall (idle, 1 kt/s, forward CG 16 % MAC), flaps 35 and gear down;
    Vref = 1.3 Vs must lie in the published 115-125 KIAS band at the maximum landing
    weight (and scale as sqrt(W) below it); the pitch attitude at Vref on a 3 deg path
    must lie in -1..+3 deg at every landing weight."""
    s = chk.stall_speed(mass_kg=mass_kg)
    vref = 1.3 * s.stall_cas_ms
    a = chk.approach_attitude(vref, mass_kg=mass_kg)
    _report(f"{mass_kg:.0f} kg Vs KCAS", s.stall_cas_ms / KT)
    _report(f"{mass_kg:.0f} kg Vref KCAS", vref / KT)
    _report(f"{mass_kg:.0f} kg pitch at Vref deg", a.pitch_rad / DEG)
    assert s.decel_ms2 == pytest.approx(1.0 * KT, rel=0.1)
    assert abs(s.cg_mac - 0.16) < 0.005
    assert a.gamma_rad == pytest.approx(-3.0 * DEG, abs=0.1 * DEG)
    assert a.cas_ms == pytest.approx(vref, abs=1.0 * KT)
    assert -1.0 * DEG <= a.pitch_rad <= 3.0 * DEG
    # the stall CLmax is a property of the wing: Vs scales with sqrt(mass) (independent check)
    vs_mlw = 1.3 * chk.stall_speed(mass_kg=chk.MLW_KG).stall_cas_ms
    assert 115.0 * KT <= vs_mlw <= 125.0 * KT
    assert vref == pytest.approx(vs_mlw * math.sqrt(mass_kg / chk.MLW_KG), rel=0.01)


@pytest.mark.slow
def test_forward_cg_raises_the_stall_speed():
    """More tail download at forward CG: Vs(16 % MAC) > Vs(30 % MAC), by ~1-2 %."""
    fwd = chk.stall_speed(cg_mac=0.16).stall_cas_ms
    aft = chk.stall_speed(cg_mac=0.30).stall_cas_ms
    assert 1.005 < fwd / aft < 1.04


@pytest.mark.slow
def test_clean_stall_near_mtow_at_95_115_kcas_and_recovers():
    r = chk.clean_stall(mass_kg=13000.0)
    _report("stall KCAS", r.stall_cas_ms / KT)
    _report("stall decel kt/s", r.decel_ms2 / KT)
    _report("CLmax", r.cl_max)
    _report("recovery altitude loss ft", r.altitude_loss_m / FT)
    assert 0.7 * KT < r.decel_ms2 < 1.3 * KT  # ~1 kt/s entry
    assert r.altitude_loss_before_m < 30.0  # altitude held until the wing stalled
    assert 95.0 <= r.stall_cas_ms / KT <= 115.0
    assert 1.4 < r.cl_max < 1.65  # facts sheet: CLmax clean ~1.5
    # recovery: nose down, speed builds, wings level, no autorotation
    assert r.alpha_after_5s_rad < 12.0 * DEG
    assert r.cas_gain_ms > 20.0 * KT
    assert r.max_bank_rad < 15.0 * DEG
    assert r.max_yaw_rate_rad_s < 5.0 * DEG
    assert r.altitude_loss_m < 1500.0 * FT


@pytest.mark.slow
def test_elevator_doublet_short_period_is_damped():
    t, q = chk.doublet("elevator", amplitude=0.1)
    peak = np.max(np.abs(q[t < 3.0]))
    late = np.max(np.abs(q[(t > 7.0) & (t < 12.0)]))
    assert peak > 2.0 * DEG  # the doublet did excite the mode
    assert late < 0.05 * peak  # 5 s after the doublet the pitch rate has died out


def _half_cycle_peaks(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """|y| at each local extremum after the input (t > 2 s)."""
    idx = [k for k in range(1, len(y) - 1) if t[k] > 2.0 and abs(y[k]) >= abs(y[k - 1]) and abs(y[k]) > abs(y[k + 1])]
    return np.abs(y[idx])


@pytest.mark.slow
def test_rudder_doublet_dutch_roll_is_damped():
    t, beta = chk.doublet("rudder", amplitude=0.2)
    peak = np.max(np.abs(beta[t < 5.0]))
    late = np.max(np.abs(beta[t > 20.0]))
    assert peak > 2.0 * DEG
    assert late < 0.05 * peak
    peaks = _half_cycle_peaks(t, beta)[:6]
    # logarithmic decrement per full cycle (two half cycles) -> damping ratio
    ratio = float(np.exp(np.mean(np.diff(np.log(peaks)))) ** 2)
    delta = -math.log(ratio)
    zeta = delta / math.sqrt(4 * math.pi**2 + delta**2)
    _report("Dutch roll damping ratio", zeta)
    assert zeta > 0.05  # Level 1 minimum is 0.08 in cruise with yaw damper off; 0.05 absolute floor


@pytest.mark.slow
def test_spiral_mode_doubles_no_faster_than_20_s():
    doubling, t, anti = chk.spiral_doubling_time(5.0 * DEG)
    _report("spiral doubling s", doubling if math.isfinite(doubling) else 1e9)
    assert abs(anti[0]) == pytest.approx(5.0 * DEG, abs=0.5 * DEG)
    assert doubling > 20.0


@pytest.mark.slow
def test_aircraft_rests_on_its_three_gear_legs():
    fdm = chk.load_saab340()
    chk.set_mass(fdm, chk.MTOW_KG, chk.FUEL_CAPACITY_KG)
    fdm["ic/terrain-elevation-ft"] = 800.0
    fdm["ic/h-agl-ft"] = 6.5  # wheels just clear of the ground
    fdm["ic/vt-kts"] = 0.0
    fdm["ic/theta-deg"] = 0.0
    fdm.run_ic()
    fdm["propulsion/set-running"] = -1
    chk.set_levers(fdm, 0.0, 0.0)
    fdm["fcs/left-brake-cmd-norm"] = 1.0
    fdm["fcs/right-brake-cmd-norm"] = 1.0
    for _ in range(2000):
        fdm.run()
    assert all(fdm[f"gear/unit[{i}]/WOW"] == 1.0 for i in range(3))
    assert abs(fdm["velocities/h-dot-fps"]) < 0.01
    assert abs(fdm["attitude/theta-deg"]) < 2.0
    assert abs(fdm["attitude/phi-deg"]) < 0.1
    assert fdm["velocities/vg-fps"] < 0.5
    # nose leg carries a tricycle's usual 5-15 % of the weight
    k_nose, k_main = 90000.0, 260000.0  # N/m, from the XML
    n = k_nose * fdm["gear/unit[0]/compression-ft"] * FT
    mains = k_main * (fdm["gear/unit[1]/compression-ft"] + fdm["gear/unit[2]/compression-ft"]) * FT
    assert 0.05 < n / (n + mains) < 0.15


def _load_bem():
    path = Path(__file__).resolve().parents[1] / "tools" / "propeller_bem.py"
    spec = importlib.util.spec_from_file_location("propeller_bem", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_propeller_xml_tables_are_the_blade_element_estimate():
    bem = _load_bem()
    js = np.array([0.0, 1.0, 2.0])
    betas = np.arange(0.0, 66.0, 5.0)  # the whole row: the C_P clip runs along blade angle
    ct, cp = bem.tables(js, betas)
    cp = bem.monotone_power(cp)
    xml = (Path(chk.AIRCRAFT_DIR) / "engine" / "saab340-prop.xml").read_text()

    def table(name):
        body = xml.split(f'<table name="{name}"')[1].split("<tableData>")[1].split("</tableData>")[0]
        rows = [list(map(float, line.split())) for line in body.strip().splitlines()]
        cols = np.array(rows[0])
        data = np.array(rows[1:])
        return cols, data[:, 0], data[:, 1:]

    for name, mine in (("C_THRUST", ct), ("C_POWER", cp)):
        cols, rows, data = table(name)
        for i, j in enumerate(js):
            for k, b in enumerate(betas):
                assert data[np.argmin(abs(rows - j)), np.argmin(abs(cols - b))] == pytest.approx(mine[i, k], abs=6e-5)
    # a propeller of this class peaks at 0.85-0.90 efficiency (McCormick ch. 6)
    cols, rows, ctab = table("C_THRUST")
    _, _, ptab = table("C_POWER")
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(ptab > 0.02, ctab * rows[:, None] / ptab, 0.0)
    assert 0.84 < eta.max() < 0.92
