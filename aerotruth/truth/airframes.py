"""Aircraft known to aerotruth: where JSBSim finds each model, its autopilot gain file,
and the speed/vertical-speed schedule a crew would fly per phase.

Every airframe plugs into the same aircraft-agnostic autopilot
(`aircraft/systems/aerotruth_autopilot.xml`); only gains and schedule differ. An aircraft
shipped in the jsbsim wheel is loaded from the wheel's own data folder: at run time a
small wrapper copy of its XML with our two <system> lines added is written to a cache
folder (never to the repository).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import jsbsim

from aerotruth.files import atomic_write_text

PACKAGE_AIRCRAFT_DIR = Path(__file__).parent / "aircraft"
SYSTEMS_DIR = PACKAGE_AIRCRAFT_DIR / "systems"
JSBSIM_DATA_DIR = Path(jsbsim.__file__).parent


@dataclass(frozen=True)
class SpeedSchedule:
    """Targets per phase. Climb and descent fly IAS; cruise flies TAS (the published SAAB
    figures are KTAS, and the acceptance test states TAS); vertical speeds in ft/min."""

    initial_ias_kt: float
    climb_ias_kt: float
    cruise_tas_kt: float
    descent_ias_kt: float
    arrival_ias_kt: float
    climb_vs_fpm: float
    descent_vs_fpm: float
    # climb power (throttle 0..1) of a level change: the climb's rate is then the flight
    # model's; None climbs at climb_vs_fpm and descends at descent_vs_fpm (a fixed schedule)
    climb_throttle: float | None = None


@dataclass(frozen=True)
class Airframe:
    name: str
    model: str
    in_jsbsim_wheel: bool
    gains_file: str
    schedule: SpeedSchedule
    # initial mass: fuel per tank (lbs) set before run_ic; None keeps the model's default
    fuel_lbs: tuple[float, ...] | None = None
    engines: int = 2
    # divergence guard (attitude limits in deg, altitude floor above the lowest runway in m)
    max_bank_deg: float = 60.0
    max_pitch_deg: float = 30.0
    min_pitch_deg: float = -20.0
    # properties set before run_ic (mass, configuration), and on entering each phase
    extra_ic: dict[str, float] = field(default_factory=dict)
    phase_properties: dict[str, dict[str, float]] = field(default_factory=dict)


AIRFRAMES: dict[str, Airframe] = {
    "737": Airframe(
        name="737",
        model="737",
        in_jsbsim_wheel=True,
        gains_file="gains_737",
        schedule=SpeedSchedule(
            initial_ias_kt=190.0,
            climb_ias_kt=250.0,
            cruise_tas_kt=320.0,
            descent_ias_kt=260.0,
            arrival_ias_kt=210.0,
            climb_vs_fpm=2500.0,
            descent_vs_fpm=-2000.0,
        ),
        # wing tanks full and part of the centre tank: ~4 h at FL240, enough for the
        # longest network leg (PANC-PADU, ~690 nm); 16,000 lb ran dry after 2.4 h
        fuel_lbs=(10000.0, 10000.0, 8000.0),
    ),
}

AIRFRAMES["saab340"] = Airframe(
    name="saab340",
    model="saab340",
    in_jsbsim_wheel=False,
    gains_file="gains_saab340",
    # speeds a SAAB 340 crew flies: V2+ climb-out clean, 160 KIAS en-route climb at max
    # rpm, cruise below the 267 KTAS the model makes at FL150 with cruise power so FL250
    # is still held by power, 220 KIAS descent (Vmo 250 KIAS), 180 KIAS clean arrival
    schedule=SpeedSchedule(
        initial_ias_kt=145.0,
        climb_ias_kt=160.0,
        cruise_tas_kt=255.0,
        descent_ias_kt=220.0,
        arrival_ias_kt=180.0,
        climb_vs_fpm=2000.0,
        descent_vs_fpm=-1500.0,
        # climb power: the published initial climb, ~2,000 fpm at MTOW at sea level
        # (../shared/saab340b-facts.md), is 1,930 fpm at 0.90 and 2,210 at 1.0 between 1,000
        # and 3,000 ft in ISA at 13,155 kg (the model's CT7-9B); 0.92 also leaves ~200 fpm
        # at FL250, the published service ceiling
        climb_throttle=0.92,
    ),
    fuel_lbs=None,  # the model's default load: 12,000 kg with 1,760 kg of fuel
    extra_ic={
        "fcs/gear-cmd-norm": 0.0,
        "gear/gear-pos-norm": 0.0,
        "fcs/flap-cmd-norm": 0.0,
        "fcs/advance-cmd-norm[0]": 1.0,
        "fcs/advance-cmd-norm[1]": 1.0,
    },
    phase_properties={
        "climb": {"fcs/advance-cmd-norm[0]": 1.0, "fcs/advance-cmd-norm[1]": 1.0},  # 1,384 rpm
        "cruise": {"fcs/advance-cmd-norm[0]": 0.0, "fcs/advance-cmd-norm[1]": 0.0},  # 1,230 rpm
        "descent": {"fcs/advance-cmd-norm[0]": 0.0, "fcs/advance-cmd-norm[1]": 0.0},
        "approach": {"fcs/advance-cmd-norm[0]": 1.0, "fcs/advance-cmd-norm[1]": 1.0},
    },
)

DEFAULT_AIRCRAFT = "saab340"


def airframe(name: str | None) -> Airframe:
    """The airframe called `name` (None: the default), with a clear error for unknown names."""
    key = DEFAULT_AIRCRAFT if name is None else name
    try:
        return AIRFRAMES[key]
    except KeyError:
        raise ValueError(f"aircraft: unknown aircraft {key!r}; expected one of {sorted(AIRFRAMES)}") from None


def airframe_names() -> list[str]:
    """Names of the known aircraft types, sorted."""
    return sorted(AIRFRAMES)


def _cache_dir() -> Path:
    base = os.environ.get("AEROTRUTH_CACHE")
    root = Path(base) if base else Path(tempfile.gettempdir()) / f"aerotruth-cache-{os.getuid()}"
    return root


_SYSTEM_LINES = '    <system file="{gains}"/>\n    <system file="aerotruth_autopilot"/>\n'
_IMU_LINE = '    <system file="aerotruth_imu"/>\n'
# the JSBSim step the autopilot's channel rates (execrate, in steps) are written for
# (systems/aerotruth_autopilot.xml: inner loops every 2 steps, 25 Hz; outer loops every 5,
# 10 Hz; LNAV every 10, 5 Hz); at another step each channel keeps its rate in Hz
# (channel_execrate), and one faster than the step runs at every step
AUTOPILOT_STEP_S = 0.02
_EXECRATE = re.compile(r'(<channel\b[^>]*\bexecrate=")(\d+)(")')


def channel_execrate(execrate: int, dt: float) -> int:
    """The execrate (steps) at a JSBSim step of `dt` s of a channel written to run every
    `execrate` steps of AUTOPILOT_STEP_S: its period in steps of dt, or 1 (every step) when
    the step is longer than its period. A period that is not a whole number of steps is
    refused (the channel would run at another rate)."""
    period_s = execrate * AUTOPILOT_STEP_S
    if dt >= period_s - 1e-12:
        return 1
    k = round(period_s / dt)
    if abs(k * dt - period_s) > 1e-9:
        raise ValueError(f"dt: a {period_s:g}-s autopilot channel is not a whole number of {dt:g}-s steps")
    return k


def systems_root(dt: float) -> Path:
    """Folder of the systems files (autopilot, gains, IMU) for a JSBSim step of `dt` s: the
    package's own at AUTOPILOT_STEP_S, else a cache copy with every channel's execrate set by
    channel_execrate (written once per content digest)."""
    if abs(dt - AUTOPILOT_STEP_S) < 1e-12:
        return SYSTEMS_DIR
    files = {
        f.name: _EXECRATE.sub(lambda m: f"{m[1]}{channel_execrate(int(m[2]), dt)}{m[3]}", f.read_text())
        for f in sorted(SYSTEMS_DIR.glob("*.xml"))
    }
    digest = hashlib.sha256(json.dumps(files, sort_keys=True).encode()).hexdigest()[:12]
    root = _cache_dir() / f"systems-{digest}"
    for name, text in files.items():
        _write_once(root / name, text)
    return root


def _write_once(target: Path, text: str) -> None:
    """`text` at `target` unless it is there already (cache files named by their content's
    digest), written under a temporary name and renamed, so concurrent writers never see
    half a file."""
    if not target.exists():
        target.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(target, text)


def with_autopilot(xml: str, gains_file: str, imu: bool = False) -> str:
    """Aircraft XML text with our gain and autopilot systems (and, with `imu`, the inertial
    truth of systems/aerotruth_imu.xml) inserted before its flight control (systems
    declared first are evaluated first each step)."""
    lines = _SYSTEM_LINES.format(gains=gains_file) + (_IMU_LINE if imu else "")
    m = re.search(r"^\s*<(flight_control|autopilot|system)\b", xml, flags=re.M)
    if m is None:
        m = re.search(r"^\s*</fdm_config>", xml, flags=re.M)
    if m is None:
        raise ValueError(
            "aircraft XML: no <flight_control>, <system> or </fdm_config> element to insert the autopilot before"
        )
    return xml[: m.start()] + "\n" + lines + xml[m.start() :]


_IO_ELEMENTS = (
    re.compile(r"<(input|output)\s[^>]*/>"),
    re.compile(r"<(input|output)\s[^>]*>.*?</\1>", flags=re.S),
)


def strip_io(xml: str) -> str:
    """Remove top-level <input port=...> and <output type=...> directives (sockets and log
    files) from an aircraft XML: truth runs open no ports and write no JSBSim logs.
    Component <input>/<output> elements carry no attributes and are kept."""
    for pattern in _IO_ELEMENTS:
        xml = pattern.sub("", xml)
    return xml


_CONTACT = re.compile(r"<contact\b.*?</contact>", flags=re.S)


def airborne_only(xml: str) -> str:
    """An aircraft XML without its ground contacts (the <contact> elements of its
    <ground_reactions>): what the truth flies. No truth flight reaches the ground: a route leg
    ends 2,000 ft above its arrival runway over a ground at the lowest runway's height, an
    approach or mission ends over the threshold with JSBSim's ground set 50 m below the runway
    (approach.py), and a flight that sinks below those ends as FlightDiverged. JSBSim
    evaluates every contact at every step, extended or not, in contact or not: the SAAB 340's
    seven (three gear, four structural) cost ~15-20 % of its step; without them an airborne
    flight is the same to the bit."""
    if xml.count("<ground_reactions") != 1:
        return xml
    head, rest = xml.split("<ground_reactions", 1)
    body, tail = rest.split("</ground_reactions>", 1)
    return head + "<ground_reactions" + _CONTACT.sub("", body) + "</ground_reactions>" + tail


def aircraft_root(af: Airframe, autopilot: bool = True, imu: bool = False) -> Path:
    """Folder to use as JSBSim's aircraft path for `af`: a cache folder holding the aircraft
    XML wrapped with the autopilot (and the inertial truth with `imu`), airborne only
    (`airborne_only`; written once per content digest). The aircraft files themselves stay
    free of the autopilot and keep their contacts, so they can be tested open-loop."""
    src_dir = (JSBSIM_DATA_DIR if af.in_jsbsim_wheel else PACKAGE_AIRCRAFT_DIR.parent) / "aircraft" / af.model
    xml = strip_io((src_dir / f"{af.model}.xml").read_text())
    if autopilot:  # the truth's aircraft (the bare one stays whole for open-loop tests)
        xml = airborne_only(with_autopilot(xml, af.gains_file, imu))
    digest = hashlib.sha256(xml.encode()).hexdigest()[:12]
    root = _cache_dir() / f"aircraft-{digest}"
    _write_once(root / af.model / f"{af.model}.xml", xml)
    return root


def engine_dir(af: Airframe) -> Path:
    return JSBSIM_DATA_DIR / "engine" if af.in_jsbsim_wheel else PACKAGE_AIRCRAFT_DIR / "engine"


@contextlib.contextmanager
def quiet_jsbsim():
    """Silence what JSBSim's C++ prints on the process's stdout (banner, trim chatter):
    file descriptor 1 goes to /dev/null for the duration."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def new_fdm(af: Airframe, dt: float, autopilot: bool = True, imu: bool = False) -> jsbsim.FGFDMExec:
    """A quiet FGFDMExec with `af` loaded at time step dt (s): the autopilot included unless
    told (its channels' rates kept in Hz where the step allows, systems_root), the inertial
    truth (imu/*) with `imu`."""
    systems = systems_root(dt) if autopilot else SYSTEMS_DIR
    if imu and not autopilot:
        raise ValueError("imu: the inertial truth is inserted with the autopilot")
    with quiet_jsbsim():
        fdm = jsbsim.FGFDMExec(str(JSBSIM_DATA_DIR))
        fdm.set_debug_level(0)
        fdm.disable_output()
        # before loading: JSBSim's FCS components (filters, PIDs, kinematics) take the time
        # step when they are built, and would otherwise keep the default 1/120 s
        fdm.set_dt(dt)
        ok = fdm.load_model_with_paths(
            af.model, str(aircraft_root(af, autopilot, imu)), str(engine_dir(af)), str(systems)
        )
    if not ok:
        raise RuntimeError(f"JSBSim could not load aircraft {af.name!r}")
    return fdm
