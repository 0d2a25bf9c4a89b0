"""The scenario file: what drive to simulate and with which sensors (pydantic schema).

A scenario is a YAML file (schema and example in ``docs/scenarios.md``). Every field carries
its unit in its name (``speed_m_s``, ``drift_deg_h``, ``mounting_arcmin``); conversion to SI
happens once, in the simulator. Shipped scenarios live in ``inmotion/scenarios/*.yaml`` and are
found by :func:`find_scenario`.

Errors in a scenario raise :class:`inmotion.errors.BadInput` naming the file and the field
(``segments.3.rate_deg_s: ...``).
"""
from __future__ import annotations

from pathlib import Path
from typing import Annotated, List, Literal, Optional, Union

from pydantic import (AfterValidator, BaseModel, ConfigDict, Field, ValidationError, field_validator,
                      model_validator)

from ..errors import BadInput

__all__ = ["Scenario", "load_scenario", "find_scenario", "scenario_dir", "shipped_scenarios",
           "SPEED_SENSORS"]

#: velocity sensors a scenario may carry (same names as the bundle files)
SPEED_SENSORS = ("radar", "ldv", "odometer")

#: largest accepted IMU-in-vehicle mounting angle per axis [arcmin]
MAX_MOUNTING_ARCMIN = 1800.0
#: largest lateral acceleration of a turn [g] (a road vehicle grips up to about 1 g)
MAX_LATERAL_G = 1.5
#: most IMU rows a scenario may ask for (about 2.4 GB while simulating; 27.8 h at 100 Hz)
MAX_IMU_ROWS = 10_000_000

Vec3 = Annotated[List[float], Field(min_length=3, max_length=3)]
ScalarOr3 = Union[float, Vec3]


def _three_or_six(v):
    if len(v) not in (3, 6):
        raise ValueError("misalignment_arcsec needs 3 or 6 values")
    return v


#: a sensor triad's misalignment [arcsec]: 3 values (a small rotation of the triad) or 6
#: (non-orthogonality xy, xz, yx, yz, zx, zy); Gyro and Accel
MisalignmentArcsec = Annotated[List[float], AfterValidator(_three_or_six)]


#: magnitudes a scenario's numbers may have (0 aside): no drive needs more, and beyond them
#: the simulator overflows or divides by almost zero
MAX_MAGNITUDE, MIN_MAGNITUDE = 1e9, 1e-12
#: the slowest sensor or IMU rate [Hz]
MIN_RATE_HZ = 0.01


def _plausible(name: str, v) -> None:
    if isinstance(v, (list, tuple)):
        for x in v:
            _plausible(name, x)
        return
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return
    x = abs(float(v))
    if x > MAX_MAGNITUDE or 0 < x < MIN_MAGNITUDE:
        raise ValueError(f"{name} = {v:g} is outside the plausible range "
                         f"{MIN_MAGNITUDE:g} .. {MAX_MAGNITUDE:g} (or 0)")
    if name.endswith(("rate_hz", "frequency_hz")) and 0 < x < MIN_RATE_HZ:
        raise ValueError(f"{name} = {v:g} Hz is below {MIN_RATE_HZ:g} Hz")


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    @model_validator(mode="after")
    def _magnitudes(self):
        for name in type(self).model_fields:
            _plausible(name, getattr(self, name))
        return self


# ----------------------------------------------------------------------------- start, vehicle
class Start(_Model):
    """Initial position and motion. Heading clockwise from North."""

    lat_deg: float = Field(ge=-89.0, le=89.0)
    lon_deg: float = Field(ge=-360.0, le=360.0)
    h_m: float = Field(ge=-500.0, le=20000.0)
    heading_deg: float = 0.0
    speed_m_s: float = Field(0.0, ge=0.0, le=150.0)


class Vehicle(_Model):
    """How the body moves on the road.

    ``roll_per_lateral_accel_deg_per_m_s2``: a car body rolls outward in a turn, about
    0.3-0.6 deg per m/s^2 of lateral acceleration (3-6 deg/g) for passenger cars and off-road
    vehicles; roll = -k * v * yaw_rate (a right turn, yaw rate > 0, rolls the body left: roll < 0).
    ``transition_s``: default length of the smooth (C3, septic smoothstep) blends at the start
    and end of every acceleration, turn and pitch change.
    ``constraint_violation``: the vehicle's side slip and bounce (:class:`ConstraintViolation`;
    absent: none, the vehicle constraint holds exactly at the IMU).
    """

    roll_per_lateral_accel_deg_per_m_s2: float = Field(0.4, ge=0.0, le=5.0)
    transition_s: float = Field(2.0, gt=0.0, le=60.0)
    constraint_violation: Optional["ConstraintViolation"] = None


class ConstraintViolation(_Model):
    """How far a real vehicle breaks its motion constraint (zero lateral and vertical velocity
    in the vehicle frame, issue 15): tyre side slip (lateral, x) and body bounce on the
    suspension (vertical, z), each a stationary first-order Gauss-Markov velocity with 1-sigma
    ``*_sigma_m_s`` and correlation time ``*_tau_s``, added to the vehicle frame's velocity at
    the IMU, faded out towards standstill by ``v^2 / (v^2 + fade_speed_m_s^2)`` (a parked
    vehicle neither slips nor bounces). Off when absent (the constraint then holds exactly).

    The simulator draws one realization per run (:func:`inmotion.sim.profile.build_profile`):
    samples every ``min(0.05 s, tau / 5)`` joined by a cubic spline, so velocity, its
    derivative (what the accelerometers sense) and the position integrate the same motion.
    Measured on real logs by ``benchmarks/constraint_violation_real.py`` (FOG INS reference of
    the PSINS moving log: lateral 0.010 m/s, 0.5 s; vertical 0.020 m/s, 0.2 s)."""

    lateral_sigma_m_s: float = Field(0.0, ge=0.0, le=5.0)
    lateral_tau_s: float = Field(0.5, gt=0.0, le=3600.0)
    vertical_sigma_m_s: float = Field(0.0, ge=0.0, le=5.0)
    vertical_tau_s: float = Field(0.2, gt=0.0, le=3600.0)
    fade_speed_m_s: float = Field(1.0, gt=0.0, le=50.0)

    @property
    def active(self) -> bool:
        return self.lateral_sigma_m_s > 0.0 or self.vertical_sigma_m_s > 0.0


Vehicle.model_rebuild()


# ----------------------------------------------------------------------------- segments
class _Seg(_Model):
    transition_s: Optional[float] = Field(None, gt=0.0, le=60.0)


class Rest(_Seg):
    """Standing still (speed must be 0) for ``duration_s``."""
    kind: Literal["rest"]
    duration_s: float = Field(gt=0.0)


class Wait(_Seg):
    """Standing still, as ``rest`` (reads naturally after ``stop``)."""
    kind: Literal["wait"]
    duration_s: float = Field(gt=0.0)


class Cruise(_Seg):
    """Constant speed and heading for ``duration_s``."""
    kind: Literal["cruise"]
    duration_s: float = Field(gt=0.0)


class Accelerate(_Seg):
    """Speed up to ``to_speed_m_s`` with acceleration ``accel_m_s2`` (the plateau value)."""
    kind: Literal["accelerate"]
    to_speed_m_s: float = Field(gt=0.0, le=150.0)
    accel_m_s2: float = Field(gt=0.0, le=10.0)


class Decelerate(_Seg):
    """Slow down to ``to_speed_m_s`` (> 0; use ``stop`` for 0) at ``decel_m_s2``."""
    kind: Literal["decelerate"]
    to_speed_m_s: float = Field(gt=0.0, le=150.0)
    decel_m_s2: float = Field(gt=0.0, le=10.0)


class Stop(_Seg):
    """Slow down to standstill at ``decel_m_s2``."""
    kind: Literal["stop"]
    decel_m_s2: float = Field(gt=0.0, le=10.0)


class Turn(_Seg):
    """Change heading by ``angle_deg`` (positive: right, clockwise) at ``rate_deg_s``."""
    kind: Literal["turn"]
    angle_deg: float
    rate_deg_s: float = Field(gt=0.0, le=90.0)

    @field_validator("angle_deg")
    @classmethod
    def _nonzero(cls, v):
        if v == 0.0:
            raise ValueError("a turn needs a non-zero angle_deg")
        return v


class Climb(_Seg):
    """Drive up a slope of ``pitch_deg`` for ``duration_s`` (blends in and out included)."""
    kind: Literal["climb"]
    pitch_deg: float = Field(gt=0.0, le=45.0)
    duration_s: float = Field(gt=0.0)


class Descend(_Seg):
    """Drive down a slope of ``pitch_deg`` (given positive) for ``duration_s``."""
    kind: Literal["descend"]
    pitch_deg: float = Field(gt=0.0, le=45.0)
    duration_s: float = Field(gt=0.0)


Segment = Annotated[Union[Rest, Wait, Cruise, Accelerate, Decelerate, Stop, Turn, Climb, Descend],
                    Field(discriminator="kind")]


# ----------------------------------------------------------------------------- disturbances
class SideSlip(_Model):
    """Lateral sliding: a vehicle-frame x (right) velocity bump ``speed_m_s * sin^4(pi s)``,
    ``s = (t - t_s) / duration_s`` in [0, 1]; negative speed slides left."""
    t_s: float
    duration_s: float = Field(gt=0.0)
    speed_m_s: float = 0.5


class Jump(_Model):
    """A vertical jolt: vehicle-frame z displacement ``height_m * sin^4(pi s)`` over the
    window."""
    t_s: float
    duration_s: float = Field(gt=0.0)
    height_m: float = 0.05


class Vibration(_Model):
    """Engine vibration in a window: sinusoidal angular oscillation of pitch, roll, yaw
    (amplitudes ``angular_amplitude_arcsec``) and linear oscillation of the body along x, y, z
    (displacement amplitudes ``linear_amplitude_mm``) at ``frequency_hz``, faded in and out over
    ``fade_s`` (C3 blend). ``phases_deg`` are the phases of the three axes (angular and linear
    alike). In phase (the default) the body rocks about one fixed axis; phase differences make
    a coning motion, which a two-sample coning algorithm at 100 Hz follows only roughly (25 Hz
    coning of a few arcsec leaves about 0.1 arcsec/min of attitude drift in the mechanization:
    a property of the algorithm, not of the increments, which stay exact)."""
    start_s: float
    end_s: float
    frequency_hz: float = Field(gt=0.0, le=1000.0)
    angular_amplitude_arcsec: ScalarOr3 = 10.0
    linear_amplitude_mm: ScalarOr3 = 0.1
    phases_deg: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    fade_s: float = Field(1.0, gt=0.0)

    @model_validator(mode="after")
    def _window(self):
        if self.end_s <= self.start_s + 2 * self.fade_s:
            raise ValueError("end_s must exceed start_s by more than 2 * fade_s")
        return self


class Disturbances(_Model):
    side_slips: List[SideSlip] = []
    jumps: List[Jump] = []
    vibration: List[Vibration] = []


# ----------------------------------------------------------------------------- sensors
class Gyro(_Model):
    """Gyro errors. ``drift_deg_h``: constant drift (scalar: each axis; or per axis).
    ``arw_deg_sqrt_h``: angle random walk. ``drift_markov_deg_h``, ``drift_markov_tau_s``:
    an optional slowly varying drift (bias instability), a first-order Markov process per axis. ``scale_factor_ppm``; ``misalignment_arcsec``: 3 values
    (a small rotation of the triad) or 6 (non-orthogonality xy, xz, yx, yz, zx, zy)."""
    drift_deg_h: ScalarOr3 = 0.0
    arw_deg_sqrt_h: float = Field(0.0, ge=0.0)
    drift_markov_deg_h: float = Field(0.0, ge=0.0)
    drift_markov_tau_s: float = Field(3600.0, gt=0.0)
    scale_factor_ppm: ScalarOr3 = 0.0
    misalignment_arcsec: MisalignmentArcsec = Field(default_factory=lambda: [0.0, 0.0, 0.0])


class Accel(_Model):
    """Accelerometer errors. ``bias_ug``: constant bias (micro-g, g = 9.80665 m/s^2).
    Velocity random walk in one of ``vrw_ug_sqrt_hz`` (white acceleration noise density) or
    ``vrw_m_s_sqrt_h`` (1 m/s/sqrt(h) = 1/60 m/s/sqrt(s)). Scale factor, misalignment and the
    Markov bias (``bias_markov_ug``, ``bias_markov_tau_s``) as Gyro."""
    bias_ug: ScalarOr3 = 0.0
    bias_markov_ug: float = Field(0.0, ge=0.0)
    bias_markov_tau_s: float = Field(3600.0, gt=0.0)
    vrw_ug_sqrt_hz: Optional[float] = Field(None, ge=0.0)
    vrw_m_s_sqrt_h: Optional[float] = Field(None, ge=0.0)
    scale_factor_ppm: ScalarOr3 = 0.0
    misalignment_arcsec: MisalignmentArcsec = Field(default_factory=lambda: [0.0, 0.0, 0.0])

    @model_validator(mode="after")
    def _one_vrw(self):
        if self.vrw_ug_sqrt_hz is not None and self.vrw_m_s_sqrt_h is not None:
            raise ValueError("give the velocity random walk once: vrw_ug_sqrt_hz or vrw_m_s_sqrt_h")
        return self


#: sensor grade presets of ``imu.grade`` (the error figures a grade fills in where the scenario
#: gives none): a representative value inside the ranges of Groves, *Principles of GNSS,
#: Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed., 2013, sec. 4.4 (tables
#: 4.1-4.2): navigation grade (ring-laser / fibre-optic gyros, servo accelerometers), tactical
#: grade (lower-cost FOG / quartz), and consumer / automotive MEMS (its bias wanders: a
#: Markov part). gnss-ins-sim's ``low`` / ``mid`` / ``high`` accuracy presets play this role.
IMU_GRADES = {
    "navigation": {"gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.002},
                   "accel": {"bias_ug": 30.0, "vrw_ug_sqrt_hz": 5.0}},
    "tactical": {"gyro": {"drift_deg_h": 1.0, "arw_deg_sqrt_h": 0.05,
                          "drift_markov_deg_h": 0.3, "drift_markov_tau_s": 1800.0},
                 "accel": {"bias_ug": 300.0, "vrw_ug_sqrt_hz": 50.0}},
    "mems": {"gyro": {"drift_deg_h": 100.0, "arw_deg_sqrt_h": 0.5,
                      "drift_markov_deg_h": 20.0, "drift_markov_tau_s": 300.0},
             "accel": {"bias_ug": 3000.0, "vrw_ug_sqrt_hz": 150.0,
                       "bias_markov_ug": 500.0, "bias_markov_tau_s": 300.0}},
}


class Imu(_Model):
    """The IMU. ``constant_errors``: ``fixed`` uses the drift, bias, scale factor and
    misalignment values as given; ``random`` draws each axis once per run from a zero-mean
    normal with the given value as 1-sigma (the drawn values are written to meta).
    ``grade``: ``navigation``, ``tactical`` or ``mems`` fills the gyro and accelerometer
    figures of :data:`IMU_GRADES` that the scenario does not give (a value given wins)."""
    rate_hz: float = Field(100.0, ge=10.0, le=10000.0)
    grade: Optional[Literal["navigation", "tactical", "mems"]] = None
    gyro: Gyro = Gyro()
    accel: Accel = Accel()
    constant_errors: Literal["fixed", "random"] = "fixed"

    @model_validator(mode="before")
    @classmethod
    def _grade_defaults(cls, data):
        if not isinstance(data, dict) or data.get("grade") not in IMU_GRADES:
            return data
        out = dict(data)
        for part, preset in IMU_GRADES[data["grade"]].items():
            given = out.get(part) or {}
            if not isinstance(given, dict):
                return data                      # let the field's own check say what is wrong
            filled = {**preset, **given}
            if part == "accel" and "vrw_m_s_sqrt_h" in given:
                filled.pop("vrw_ug_sqrt_hz", None)   # the scenario's own VRW, in its unit
            out[part] = filled
        return out


class _SpeedSensor(_Model):
    """Common to the forward-velocity sensors.

    ``lever_arm_m``: sensor position in the IMU frame b (right, forward, up) from the IMU [m].
    ``mounting_arcmin``: [alpha, beta, gamma], the sensor's own small *beam misalignment*
    relative to the vehicle frame v (``C_s^v = exp([A_s x])``); it changes the reading only to
    second order (a cosine). The first-order angles are the IMU's in the vehicle,
    :attr:`Scenario.vehicle_mounting_arcmin`; see :mod:`inmotion.sim.sensors`.
    ``scale_factor_ppm``: constant scale factor error; ``scale_factor_sigma_ppm``: if > 0, a
    per-run random constant is added (1-sigma). ``noise_m_s``: white noise on the speed.
    """
    rate_hz: float = Field(gt=0.0, le=10000.0)
    lever_arm_m: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    mounting_arcmin: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    scale_factor_ppm: float = 0.0
    scale_factor_sigma_ppm: float = Field(0.0, ge=0.0)
    noise_m_s: float = Field(0.0, ge=0.0)


class Radar(_SpeedSensor):
    """Doppler radar: forward speed; scale factor error adds a first-order Markov process
    (paper 000 eq. 3) with stationary 1-sigma ``scale_markov_sigma_ppm`` and correlation time
    ``scale_markov_tau_s``."""
    scale_markov_sigma_ppm: float = Field(0.0, ge=0.0)
    scale_markov_tau_s: float = Field(300.0, gt=0.0)


class Ldv(_SpeedSensor):
    """Laser Doppler velocimeter: forward speed (``output: speed``, file column ``v``) or
    distance increments (``output: distance``, column ``ds``; the noise is then
    ``noise_m_s`` times the sample period)."""
    output: Literal["speed", "distance"] = "speed"


class Odometer(_SpeedSensor):
    """Wheel odometer: counts ``pulses_per_m`` pulses per metre of (scale-factor-affected)
    wheel distance; the output is distance increments ``ds`` = whole pulses / pulses_per_m over
    each sample period, so the quantization is 1 / pulses_per_m and never accumulates."""
    pulses_per_m: float = Field(gt=0.0, le=1e6)


class Baro(_Model):
    """Barometric altimeter: ``h = h_true + bias + noise``; ``bias = bias_m`` plus, if
    ``bias_sigma_m > 0``, a per-run random constant of that 1-sigma."""
    rate_hz: float = Field(gt=0.0, le=10000.0)
    bias_m: float = 0.0
    bias_sigma_m: float = Field(0.0, ge=0.0)
    noise_m: float = Field(0.0, ge=0.0)


class Sensors(_Model):
    radar: Optional[Radar] = None
    ldv: Optional[Ldv] = None
    odometer: Optional[Odometer] = None
    baro: Optional[Baro] = None


# ----------------------------------------------------------------------------- faults
class Fault(_Model):
    """A fault of one sensor in ``[start_s, end_s)``. Kinds and their fields:

    - ``offset``: ``offset_m_s`` (speed sensors) or ``offset_m`` (baro) added;
    - ``scale``: the output multiplied by ``1 + scale_ppm * 1e-6``;
    - ``stuck``: the output frozen at its last value before the window;
    - ``dropout``: no samples in the window;
    - ``outliers``: each sample, with probability ``probability``, gets an added error drawn
      uniformly in ``[-magnitude, +magnitude]`` (``magnitude_m_s`` or ``magnitude_m``);
    - ``slip`` (odometer): the wheel spins faster than the vehicle moves, reading
      ``1 + slip_ratio`` times the distance;
    - ``idle`` (odometer): the wheel turns with the vehicle not moving as it says, adding
      ``idle_speed_m_s`` of apparent speed.
    """
    sensor: Literal["radar", "ldv", "odometer", "baro"]
    kind: Literal["offset", "scale", "stuck", "dropout", "outliers", "slip", "idle"]
    start_s: float
    end_s: float
    offset_m_s: Optional[float] = None
    offset_m: Optional[float] = None
    scale_ppm: Optional[float] = None
    probability: Optional[float] = Field(None, gt=0.0, le=1.0)
    magnitude_m_s: Optional[float] = Field(None, gt=0.0)
    magnitude_m: Optional[float] = Field(None, gt=0.0)
    slip_ratio: Optional[float] = Field(None, gt=-1.0)
    idle_speed_m_s: Optional[float] = None

    @model_validator(mode="after")
    def _fields(self):
        if self.end_s <= self.start_s:
            raise ValueError("end_s must be after start_s")
        speed = self.sensor != "baro"
        need = {"offset": ["offset_m_s" if speed else "offset_m"], "scale": ["scale_ppm"],
                "stuck": [], "dropout": [],
                "outliers": ["probability", "magnitude_m_s" if speed else "magnitude_m"],
                "slip": ["slip_ratio"], "idle": ["idle_speed_m_s"]}[self.kind]
        if self.kind in ("slip", "idle") and self.sensor != "odometer":
            raise ValueError(f"fault kind {self.kind!r} exists only for the odometer")
        for name in need:
            if getattr(self, name) is None:
                raise ValueError(f"a {self.kind!r} fault of the {self.sensor} needs {name}")
        return self


# ----------------------------------------------------------------------------- scenario
class Scenario(_Model):
    """One simulated drive: the motion, the disturbances, the sensors and their faults.

    ``vehicle_mounting_arcmin``: ``A = [alpha, beta, gamma]``, how the IMU sits in the vehicle:
    the vehicle frame v seen from the IMU frame b, ``C_v^b = exp([A x])``
    (:func:`inmotion.core.rotations.mounting_dcm`; paper 000 eq. 4-9, docs/ARCHITECTURE.md
    "Vehicle frame and mounting"). The segments move v; the IMU turns with it, offset by A.
    At most 1800 arcmin (30 deg) per axis (a larger value is most likely degrees or a typo).
    """
    name: str
    description: str = ""
    start: Start
    vehicle_mounting_arcmin: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    vehicle: Vehicle = Vehicle()
    segments: List[Segment] = Field(min_length=1)
    disturbances: Disturbances = Disturbances()
    imu: Imu = Imu()
    sensors: Sensors = Sensors()
    faults: List[Fault] = []
    quadrature_nodes: Optional[int] = Field(None, ge=2, le=8)

    @field_validator("vehicle_mounting_arcmin")
    @classmethod
    def _small_mounting(cls, v):
        if max(abs(x) for x in v) > MAX_MOUNTING_ARCMIN:
            raise ValueError(f"{list(v)} arcmin: each angle must be within "
                             f"+-{MAX_MOUNTING_ARCMIN:g} arcmin (30 deg); degrees given?")
        return v

    @model_validator(mode="after")
    def _consistent(self):
        for i, f in enumerate(self.faults):
            if getattr(self.sensors, f.sensor) is None:
                raise ValueError(f"faults.{i}: sensor {f.sensor!r} is not in sensors")
        rate = self.imu.rate_hz
        for name in ("radar", "ldv", "odometer", "baro"):
            s = getattr(self.sensors, name)
            if s is not None:
                ratio = rate / s.rate_hz
                if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
                    raise ValueError(f"sensors.{name}.rate_hz: {s.rate_hz} Hz must divide the "
                                     f"IMU rate {rate} Hz (the simulator samples on IMU times)")
        return self

    @property
    def nodes(self) -> int:
        """Gauss-Legendre nodes per IMU interval: ``quadrature_nodes`` if given, else 3 (exact
        to round-off for the C3 driving motion: 3 and 8 nodes agree to 1e-17 rad, 5e-16 m/s per
        increment at 100 Hz), or 6 when a vibration has more than 0.05 cycles per IMU interval
        (at 25 Hz and 100 Hz, 4 nodes leave 1e-12 rad per increment, 6 nodes 1e-16)."""
        if self.quadrature_nodes is not None:
            return self.quadrature_nodes
        fast = any(v.frequency_hz > 0.05 * self.imu.rate_hz for v in self.disturbances.vibration)
        return 6 if fast else 3

    @property
    def present_sensors(self) -> list[str]:
        return [n for n in ("radar", "ldv", "odometer", "baro") if getattr(self.sensors, n)]


def _known_keys() -> set:
    """Every field name of the scenario schema (for "did you mean")."""
    out, todo = set(), list(_Model.__subclasses__())
    while todo:
        cls = todo.pop()
        out.update(cls.model_fields)
        todo.extend(cls.__subclasses__())
    return out


def _format_error(e: ValidationError) -> str:
    import difflib
    errors = e.errors()
    extra = [x for x in errors if x["type"] == "extra_forbidden"]
    err = extra[0] if extra else errors[0]
    loc = ".".join(str(x) for x in err["loc"]
                   if not str(x).startswith(("function-after", "list[")) and str(x) != "float")
    msg = err["msg"].removeprefix("Value error, ")
    if extra:
        key = str(err["loc"][-1])
        close = difflib.get_close_matches(key, sorted(_known_keys()), n=1, cutoff=0.6)
        msg = f"unknown key {key!r}" + (f"; did you mean {close[0]!r}?" if close else "")
        errors = extra
    more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
    return f"{loc}: {msg}{more}" if loc else msg + more


def load_scenario(source) -> Scenario:
    """A :class:`Scenario` from a YAML path, a shipped scenario name, a dict, or a Scenario.

    Raises
    ------
    BadInput
        naming the file and the first offending field.
    """
    if isinstance(source, Scenario):
        return source
    file = None
    if not isinstance(source, (dict, str, Path)):
        raise BadInput(f"a scenario must be a mapping, a file or a shipped name, got "
                       f"{type(source).__name__} {source!r}"[:160])
    if isinstance(source, dict):
        data = source
    else:
        path = Path(source)
        if not path.exists() and path.suffix == "" and (scenario_dir() / f"{path}.yaml").exists():
            path = scenario_dir() / f"{path}.yaml"
        file = str(path)
        if not path.is_file():
            raise BadInput("scenario file not found", file=file)
        from ..io.safe_yaml import load_yaml_file
        data = load_yaml_file(path, "scenario", invalid="not valid YAML")
        if not isinstance(data, dict):
            raise BadInput("a scenario must be a YAML mapping", file=file)
    try:
        sc = Scenario.model_validate(data)
    except ValidationError as e:
        raise BadInput(_format_error(e), file=file or "scenario") from None
    _check_motion(sc, file or "scenario")
    return sc


def _check_motion(sc: Scenario, file: str) -> None:
    """Segment sequences that no vehicle can drive (turning or climbing at standstill ...)."""
    import math
    v = sc.start.speed_m_s
    duration = 0.0
    for i, seg in enumerate(sc.segments):
        where = f"segments.{i} ({seg.kind})"
        if seg.kind == "turn":
            lateral = v * math.radians(seg.rate_deg_s)
            if lateral > MAX_LATERAL_G * 9.80665:
                raise BadInput(f"{where}: turning at {seg.rate_deg_s:g} deg/s at {v:g} m/s is a "
                               f"lateral acceleration of {lateral / 9.80665:.3g} g; no road "
                               f"vehicle holds more than {MAX_LATERAL_G:g} g", file=file)
        duration += _segment_duration(seg, v)
        if seg.kind in ("rest", "wait") and v != 0.0:
            raise BadInput(f"{where}: the vehicle must be stopped to {seg.kind} "
                           f"(speed is {v} m/s; add a stop first)", file=file)
        if seg.kind in ("turn", "climb", "descend", "cruise", "stop") and v == 0.0:
            raise BadInput(f"{where}: the vehicle is at standstill; accelerate first", file=file)
        if seg.kind == "accelerate" and seg.to_speed_m_s <= v:
            raise BadInput(f"{where}: to_speed_m_s {seg.to_speed_m_s} is not above the current "
                           f"speed {v} m/s", file=file)
        if seg.kind == "decelerate" and seg.to_speed_m_s >= v:
            raise BadInput(f"{where}: to_speed_m_s {seg.to_speed_m_s} is not below the current "
                           f"speed {v} m/s", file=file)
        if seg.kind in ("accelerate", "decelerate"):
            v = seg.to_speed_m_s
        elif seg.kind == "stop":
            v = 0.0
    rows = duration * sc.imu.rate_hz
    if rows > MAX_IMU_ROWS:
        raise BadInput(f"the drive lasts about {duration / 3600:.4g} h, {rows:.3g} IMU rows at "
                       f"{sc.imu.rate_hz:g} Hz; at most {MAX_IMU_ROWS:.3g} rows are simulated "
                       "at once (split the drive, or lower imu.rate_hz)", file=file)


def _segment_duration(seg, v) -> float:
    """About how long a segment lasts [s] (blends not counted)."""
    if hasattr(seg, "duration_s"):
        return float(seg.duration_s)
    if seg.kind == "turn":
        return abs(seg.angle_deg) / seg.rate_deg_s
    if seg.kind == "accelerate":
        return abs(seg.to_speed_m_s - v) / seg.accel_m_s2
    if seg.kind == "decelerate":
        return abs(v - seg.to_speed_m_s) / seg.decel_m_s2
    if seg.kind == "stop":
        return v / seg.decel_m_s2
    return 0.0


def scenario_dir() -> Path:
    """The folder of the shipped scenario files."""
    return Path(__file__).resolve().parent.parent / "scenarios"


def shipped_scenarios() -> list[str]:
    return sorted(p.stem for p in scenario_dir().glob("*.yaml"))


def find_scenario(name: str) -> Path:
    """Path of the shipped scenario ``name`` (with or without ``.yaml``)."""
    stem = name[:-5] if name.endswith(".yaml") else name
    path = scenario_dir() / f"{stem}.yaml"
    if not path.is_file():
        raise BadInput(f"no shipped scenario {stem!r}; shipped: {', '.join(shipped_scenarios())}")
    return path
