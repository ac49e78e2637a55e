"""Blade-element/momentum estimate of the SAAB 340B propeller's C_T and C_P tables.

Regenerates the numbers in ``saab340-prop.xml`` (run ``python tools/propeller_bem.py``).
Method: strip theory with annular momentum and Prandtl tip loss, axial and swirl
induction found by the circulation/momentum balance (Glauert's propeller theory as
presented in McCormick, *Aerodynamics, Aeronautics and Flight Mechanics*, 2nd ed.,
ch. 6, eqs. 6.23-6.35); airfoil polars are a thin cambered section (lift slope
5.7/rad, zero-lift angle -2 deg, cl_max 1.3, Hoerner-type flat-plate post-stall).
Geometry is an estimate for a 3.35 m, 4-blade wide-chord composite blade of the
SAAB 340B (diameter and blade count: Jane's All the World's Aircraft, SAAB 340B
entry); chord and twist are textbook choices (Raymer, *Aircraft Design*, 6th ed.,
sect. 13.6: activity factor ~ 100-140 per blade for turboprop blades).
Compressibility (Prandtl-Glauert lift slope, Korn drag-divergence Mach with Lock's
fourth-power drag rise): the base tables are computed at rotational tip Mach 0.60,
and JSBSim's CT_MACH / CP_MACH multipliers versus helical tip Mach are the ratio of
the loads at each tip Mach to the base, at the climb/cruise point J 1.5, 37 deg.
"""

from __future__ import annotations

import numpy as np

R_TIP = 3.35 / 2.0  # m
R_HUB = 0.20 * R_TIP  # spinner
N_BLADES = 4
N_ELEM = 40
DESIGN_J = 1.7  # helical-pitch twist chosen for the cruise advance ratio

# chord / R along x = r/R (wide-chord composite blade, est.)
_X_CH = np.array([0.20, 0.35, 0.50, 0.65, 0.80, 0.90, 1.00])
_C_CH = np.array([0.150, 0.190, 0.205, 0.200, 0.180, 0.155, 0.095])
# thickness / chord along x (thick root, thin tip)
_X_TC = np.array([0.20, 0.50, 0.75, 1.00])
_TC = np.array([0.20, 0.09, 0.06, 0.04])
TIP_MACH_ROT = 0.60  # rotational tip Mach of the base tables (low-speed reference)
REF_J, REF_BETA = 1.5, 37.0  # operating point for the tip-Mach correction tables


def chord_over_r(x: np.ndarray) -> np.ndarray:
    """Blade chord divided by tip radius at stations x = r/R."""
    return np.interp(x, _X_CH, _C_CH)


def twist_deg(x: np.ndarray) -> np.ndarray:
    """Blade angle relative to the 0.75 R angle: ideal helical twist for DESIGN_J."""
    return np.degrees(np.arctan(DESIGN_J / (np.pi * x)) - np.arctan(DESIGN_J / (np.pi * 0.75)))


def activity_factor() -> float:
    """Activity factor per blade, AF = 1e5/16 * int_{hub}^{1} (c/D) x^3 dx."""
    x = np.linspace(R_HUB / R_TIP, 1.0, 400)
    return float(1e5 / 16.0 * np.trapezoid(chord_over_r(x) / 2.0 * x**3, x))


def airfoil(alpha: np.ndarray, mach: np.ndarray, tc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Section lift and drag coefficients for angle of attack alpha (rad).

    Attached flow: thin-aerofoil slope 5.7/rad (Prandtl-Glauert corrected),
    zero-lift angle -2 deg, parabolic polar plus Korn/Lock drag rise. Past the
    stall angles the coefficients blend over 25 deg into the flat-plate values
    cl = sin 2a, cd = 1.9 sin^2 a + 0.02 (Hoerner, *Fluid-Dynamic Drag*, ch. 3;
    *Fluid-Dynamic Lift*, ch. 4); the slow blend stands for the stall delay of
    rotating blades (Himmelskamp effect), which keeps blade lift near its maximum.
    """
    a0 = 5.7 / np.sqrt(1.0 - np.minimum(mach, 0.8) ** 2)  # Prandtl-Glauert
    al0 = np.radians(-2.0)
    a_pos = al0 + 1.3 / a0  # positive stall, cl_max = 1.3
    a_neg = al0 - 0.9 / a0  # negative stall, cl_min = -0.9
    cl_att = a0 * (alpha - al0)
    # Korn drag divergence (kappa 0.87) with Lock's fourth-power drag rise
    m_dd = 0.87 - tc - np.clip(cl_att, 0, None) / 10.0
    m_cr = m_dd - (0.1 / 80.0) ** (1.0 / 3.0)
    wave = 20.0 * np.clip(mach - m_cr, 0.0, None) ** 4
    cd_att = 0.0095 + 0.014 * (cl_att - 0.4) ** 2 + wave
    cl_fp = np.sin(2 * alpha)
    cd_fp = 1.9 * np.sin(alpha) ** 2 + 0.02
    over = np.clip((alpha - a_pos) / np.radians(25.0), 0.0, 1.0)
    under = np.clip((a_neg - alpha) / np.radians(25.0), 0.0, 1.0)
    cd_pos = 0.0095 + 0.014 * 0.9**2 + wave
    cd_neg = 0.0095 + 0.014 * 1.3**2 + wave
    cl = np.where(
        over > 0, (1 - over) * 1.3 + over * cl_fp, np.where(under > 0, (1 - under) * -0.9 + under * cl_fp, cl_att)
    )
    cd = np.where(
        over > 0,
        np.maximum((1 - over) * cd_pos + over * cd_fp, cd_pos),
        np.where(under > 0, np.maximum((1 - under) * cd_neg + under * cd_fp, cd_neg), cd_att),
    )
    return cl, cd


def element_loads(beta75_deg: float, j: float, tip_mach_rot: float = TIP_MACH_ROT) -> tuple[float, float]:
    """C_T and C_P (n-based: T = C_T rho n^2 D^4, P = C_P rho n^3 D^5) at one blade angle and J."""
    d = 2 * R_TIP
    n = 1.0  # rev/s; coefficients are independent of the scale
    omega = 2 * np.pi * n
    v = j * n * d
    edges = np.linspace(R_HUB, R_TIP, N_ELEM + 1)
    r = 0.5 * (edges[1:] + edges[:-1])
    dr = np.diff(edges)
    x = r / R_TIP
    c = chord_over_r(x) * R_TIP
    beta = np.radians(beta75_deg + twist_deg(x))
    tc = np.interp(x, _X_TC, _TC)
    mach = tip_mach_rot * np.sqrt(x**2 + (j / np.pi) ** 2)
    va = np.full_like(r, 0.05 * omega * R_TIP)  # axial induced velocity
    vt = np.zeros_like(r)  # swirl induced velocity
    for _ in range(300):
        ua = v + va
        ut = np.maximum(omega * r - vt, 1e-6)
        phi = np.arctan2(ua, ut)
        w2 = ua**2 + ut**2
        alpha = beta - phi
        cl, cd = airfoil(alpha, mach, tc)
        # Prandtl tip loss (McCormick eq. 6.31)
        f_exp = N_BLADES / 2.0 * (1 - x) / (x * np.maximum(np.sin(np.abs(phi)), 1e-3))
        tip = 2 / np.pi * np.arccos(np.clip(np.exp(-f_exp), 0.0, 1.0))
        tip = np.maximum(tip, 1e-3)
        cx = cl * np.cos(phi) - cd * np.sin(phi)
        cy = cl * np.sin(phi) + cd * np.cos(phi)
        dT_be = 0.5 * w2 * N_BLADES * c * cx  # per unit rho, per dr
        dQ_be = 0.5 * w2 * N_BLADES * c * cy * r
        # momentum: dT = 4 pi r F (V + va) va ; dQ = 4 pi r^2 F (V + va) vt
        # solve the axial balance for va (quadratic in va for the current loads)
        # braking (negative thrust) annuli: linearised momentum, wake slowed at most 40 %
        disc = v**2 + dT_be / (np.pi * r * tip)
        va_brake = np.maximum(dT_be / (4 * np.pi * r * tip * max(v, 1e-3)), -0.4 * v)
        va_new = np.where(dT_be >= 0, 0.5 * (-v + np.sqrt(np.maximum(disc, 0.0))), va_brake)
        mflux = 4 * np.pi * r**2 * tip * np.maximum(v + va_new, 1e-3)
        vt_new = np.clip(dQ_be / mflux, -0.5 * omega * r, 0.5 * omega * r)
        err = np.max(np.abs(va_new - va)) + np.max(np.abs(vt_new - vt))
        va = 0.7 * va + 0.3 * va_new
        vt = 0.7 * vt + 0.3 * vt_new
        if err < 1e-7 * omega * R_TIP:
            break
    thrust = float(np.sum(dT_be * dr))
    torque = float(np.sum(dQ_be * dr))
    ct = thrust / (n**2 * d**4)
    cp = torque * omega / (n**3 * d**5)
    return ct, cp


def tables(js: np.ndarray, betas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """C_T and C_P on the grid rows J, columns blade angle at 0.75 R (deg)."""
    ct = np.zeros((len(js), len(betas)))
    cp = np.zeros_like(ct)
    for i, j in enumerate(js):
        for k, b in enumerate(betas):
            ct[i, k], cp[i, k] = element_loads(float(b), float(j))
    return ct, cp


def mach_factors(helical_tip_mach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """C_T and C_P multipliers versus helical tip Mach, relative to the base tables.

    Evaluated at the climb/cruise operating point (REF_J, REF_BETA): the rotational tip
    Mach giving each helical tip Mach at REF_J, divided by the base-table value.
    """
    ct0, cp0 = element_loads(REF_BETA, REF_J)
    scale = np.sqrt(1.0 + (REF_J / np.pi) ** 2)
    fct, fcp = [], []
    for mh in helical_tip_mach:
        ct, cp = element_loads(REF_BETA, REF_J, tip_mach_rot=float(mh) / scale)
        fct.append(ct / ct0)
        fcp.append(cp / cp0)
    return np.array(fct), np.array(fcp)


def monotone_power(cp: np.ndarray) -> np.ndarray:
    """C_P made non-decreasing in blade angle (columns).

    In deep blade stall the strip model lets C_P dip as pitch rises; a governor
    that adds pitch to absorb power would then run away. A stalled blade's
    profile drag grows with pitch, so the dip is an artefact: clip it.
    """
    return np.maximum.accumulate(cp, axis=1)


def _table(name: str, js: np.ndarray, betas: np.ndarray, tab: np.ndarray) -> str:
    head = "          " + "".join(f"{b:8.0f}" for b in betas)
    rows = [f"   {j:5.2f}  " + "".join(f"{v:8.4f}" for v in row) for j, row in zip(js, tab, strict=False)]
    body = "\n".join([head, *rows])
    return f'  <table name="{name}" type="internal">\n    <tableData>\n{body}\n    </tableData>\n  </table>'


HEADER = """<?xml version="1.0"?>
<!--
  SAAB 340B propeller: 4 blades, 3.35 m (11 ft) diameter, constant speed
  (Jane's All the World's Aircraft, SAAB 340B entry; Dowty Rotol composite blades).

  Governor: manual-pitch mode (constspeed 0); the blade angle is written by the
  propeller governors in saab340.xml (a damped PI on rpm: JSBSim's built-in
  constant-speed governor is a pure integrator on an undamped rpm loop and hunts).
  fcs/advance-cmd-norm 0 -> 1,230 rpm (cruise), 1 -> 1,384 rpm (take-off / climb /
  approach) (SAAB 340B facts sheet); minrpm/maxrpm record that range.
  gearratio 1: the CT7-9B engine table is written in propeller rpm (the reduction
  gearbox is lumped into the engine). Ixx: four blades of about 30 kg each as slender
  rods (n m R^2 / 3 = 112 kg m^2) plus hub, spinner and the power turbine reflected
  through the gearbox, about 175 kg m^2 = 130 slug ft^2 (est.).
  Blade angle limits: 10 deg flight-fine stop (est.) to 65 deg (feathering is not
  modelled).

  C_THRUST / C_POWER (rows advance ratio J = V/(nD), columns blade angle at 0.75 R,
  deg; T = C_T rho n^2 D^4, P = C_P rho n^3 D^5) are OUR blade-element/momentum
  estimate, generated by tools/propeller_bem.py (strip theory with Prandtl
  tip loss and swirl, McCormick, Aerodynamics, Aeronautics and Flight Mechanics,
  ch. 6; chord/thickness/twist estimates, activity factor ~127 per blade), base
  tables at rotational tip Mach 0.60; CT_MACH / CP_MACH (versus helical tip Mach)
  carry the Korn/Lock compressibility loss (efficiency -4 % at 0.90, -8 % at 0.95).
  C_P is clipped to be non-decreasing in blade angle (see monotone_power). Regenerate with
  `python tools/propeller_bem.py > aerotruth/truth/aircraft/engine/saab340-prop.xml`.
-->
<propeller name="saab340-prop">
  <ixx unit="SLUG*FT2"> 130.0 </ixx>
  <diameter unit="IN"> 131.9 </diameter>
  <numblades> 4 </numblades>
  <gearratio> 1.0 </gearratio>
  <minpitch> 10 </minpitch>
  <maxpitch> 65 </maxpitch>
  <minrpm> 1230 </minrpm>
  <maxrpm> 1384 </maxrpm>
  <constspeed> 0 </constspeed>
"""


def _table1(name: str, xs: np.ndarray, ys: np.ndarray) -> str:
    rows = "\n".join(f"      {x:5.2f}  {y:7.4f}" for x, y in zip(xs, ys, strict=False))
    return f'  <table name="{name}" type="internal">\n    <tableData>\n{rows}\n    </tableData>\n  </table>'


if __name__ == "__main__":
    J = np.round(np.arange(0.0, 3.41, 0.2), 2)
    B = np.arange(0.0, 66.0, 5.0)
    ct_tab, cp_tab = tables(J, B)
    cp_tab = monotone_power(cp_tab)
    M = np.array([0.50, 0.60, 0.70, 0.75, 0.80, 0.85, 0.90, 0.95, 1.00])
    f_ct, f_cp = mach_factors(M)
    print(
        HEADER
        + "\n".join(
            [
                _table("C_THRUST", J, B, ct_tab),
                _table("C_POWER", J, B, cp_tab),
                _table1("CT_MACH", M, f_ct),
                _table1("CP_MACH", M, f_cp),
            ]
        )
        + "\n</propeller>"
    )
