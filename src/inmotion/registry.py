"""The list of methods: stable names, what they are, where they live.

A method is a function ``run(bundle, config, init) -> Solution`` in ``inmotion.align`` or
``inmotion.navigate``, with ``bundle`` an :class:`inmotion.core.bundle.Bundle`, ``config`` an
instance of the method's pydantic configuration class (human units in field names, converted
to SI inside the method, echoed back in ``Solution.info['config']``), and ``init`` a
:class:`inmotion.core.solution.NavState` or ``None`` (methods with ``needs_attitude=False``
use only its position and velocity, or nothing). An optional keyword ``progress`` takes a
callable ``progress(fraction)`` for long work. Methods never read files and never print.

Each method module adds itself to ``_SPECS`` below, one line per method; entries are imported
lazily, so listing methods imports nothing heavy. A method outside the package (a user's own
module, ``docs/extending.md``) is added at run time with :func:`register`.
"""
from __future__ import annotations

import functools
import importlib
from dataclasses import dataclass
from typing import Any, Callable

__all__ = ["MethodSpec", "methods", "get", "register", "SPEED_SENSORS", "REQUIRES",
           "present_sensors", "missing_sensors", "runnable", "check_sensors", "sensors_used",
           "add_nis_warnings"]


@dataclass(frozen=True)
class MethodSpec:
    name: str            #: stable lower-case hyphenated name
    kind: str            #: "align" or "navigate"
    entry: str           #: "module:function" of ``run(bundle, config, init, progress=None)``
    config: str          #: "module:Class" of the pydantic configuration
    needs_attitude: bool  #: False: the method finds the attitude itself and ignores init's
    summary: str         #: one line for ``inmotion methods``

    def load(self) -> tuple[Callable[..., Any], type]:
        """``(run, ConfigClass)``, imported now.

        ``run`` first checks the bundle against the method's sensor needs
        (:func:`check_sensors`: ``BadInput`` naming what is missing and the methods that can
        run instead) and records in ``Solution.info`` the sensors the bundle has
        (``sensors_present``) and those the method used (``sensors_used``).
        """
        run = _resolve(self.entry)
        name = self.name

        @functools.wraps(run)
        def checked(bundle, *args, **kwargs):
            check_sensors(name, bundle)
            sol = run(bundle, *args, **kwargs)
            info = getattr(sol, "info", None)
            if isinstance(info, dict):
                info.setdefault("sensors_present", present_sensors(bundle))
                info.setdefault("sensors_used", sensors_used(info))
                add_nis_warnings(info)
            return sol
        return checked, _resolve(self.config)


def add_nis_warnings(info: dict) -> None:
    """Append to ``info['warnings']`` :func:`inmotion.estimation.chi2.nis_warnings` of
    ``info['nis']``: every Kalman-type method's summary warns where a measurement kind's
    residuals are larger than its noise model (issue 15). ``info['warnings']`` is created only
    when there is one."""
    from .estimation.chi2 import nis_warnings
    new = [w for w in nis_warnings(info.get("nis")) if w not in (info.get("warnings") or [])]
    if new:
        info["warnings"] = list(info.get("warnings") or []) + new


def _resolve(path):
    mod, _, attr = path.partition(":")
    return getattr(importlib.import_module(mod), attr)


_SPECS = [
    MethodSpec("sins", "navigate", "inmotion.navigate.pure:run_sins",
               "inmotion.navigate.pure:SinsConfig", True,
               "pure strapdown inertial navigation (optional barometric height damping)"),
    MethodSpec("dr", "navigate", "inmotion.navigate.pure:run_dr",
               "inmotion.navigate.pure:DrConfig", True,
               "pure dead reckoning: gyro attitude + forward-velocity sensor (paper 002)"),
    MethodSpec("sins-dr", "navigate", "inmotion.navigate.sins_dr:run_sins_dr", "inmotion.navigate.sins_dr:SinsDrConfig", True, "SINS / radar dead-reckoning integrated position and orientation, attitude+position or velocity+position, 22-state KF (paper 002)"),
    MethodSpec("dr-kf", "align", "inmotion.align.dr_kalman:run_dr_kf", "inmotion.align.dr_kalman:DrKfConfig", True, "SINS / radar dead-reckoning fine alignment in motion, attitude + velocity + NHC, 25-state KF (paper 000)"),
    MethodSpec("od-velocity-kf", "align", "inmotion.align.dr_kalman:run_od_velocity_kf", "inmotion.align.dr_kalman:OdVelocityKfConfig", True, "SINS / velocity-sensor velocity-matching fine alignment, 19-state KF (baseline for dr-kf)"),
    MethodSpec("imada-vb", "align", "inmotion.align.imada:run_imada_vb", "inmotion.align.imada:ImadaConfig", False, "in-motion attitude determination, body-velocity aided, omega_ie x V^b dropped (paper 004 eq. 9)"),
    MethodSpec("imada-vn", "align", "inmotion.align.imada:run_imada_vn", "inmotion.align.imada:ImadaConfig", False, "in-motion attitude determination, navigation-velocity model (paper 004 eq. 10)"),
    MethodSpec("imada-dual", "align", "inmotion.align.imada:run_imada_dual", "inmotion.align.imada:ImadaConfig", False, "in-motion attitude determination, dual velocity modelling (paper 004 eq. 11-19)"),
    MethodSpec("mimada", "align", "inmotion.align.imada:run_mimada", "inmotion.align.imada:MimadaConfig", False, "multistage IMADA: imada-vb then imada-vn levels (paper 004 sec. 2.2)"),
    MethodSpec("mimada-dual", "align", "inmotion.align.imada:run_mimada_dual", "inmotion.align.imada:MimadaConfig", False, "improved multistage IMADA: imada-vb then imada-dual levels (paper 004 sec. 3)"),
    MethodSpec("usque", "align", "inmotion.align.usque:run_usque", "inmotion.align.usque:UsqueConfig", False, "unscented quaternion estimator with GRP attitude error, LDV-aided, from q = [1 0 0 0] (paper 001 scheme 3)"),
    MethodSpec("ausque", "align", "inmotion.align.usque:run_ausque", "inmotion.align.usque:AusqueConfig", False, "USQUE + adaptive measurement noise with fading factor and bounds (paper 001 scheme 4)"),
    MethodSpec("usque-hinf", "align", "inmotion.align.usque:run_usque_hinf", "inmotion.align.usque:UsqueHinfConfig", False, "USQUE + H-infinity covariance update with fixed gamma (paper 001 scheme 5)"),
    MethodSpec("ausquhe", "align", "inmotion.align.usque:run_ausquhe", "inmotion.align.usque:AusquheConfig", False, "adaptive unscented quaternion H-infinity estimator: adaptive R and adaptive gamma (paper 001 scheme 1)"),
    MethodSpec("oba", "align", "inmotion.align.imada:run_oba", "inmotion.align.imada:ImadaConfig", False, "optimization-based alignment vectors with Earth-rate term, q-method (paper 001 eq. 12-19)"),
    MethodSpec("coarse-inertial", "align", "inmotion.align.coarse_inertial:run_coarse_inertial", "inmotion.align.coarse_inertial:CoarseInertialConfig", False, "inertial-frame coarse alignment, parked or in motion (paper 003 eq. 1-10)"),
    MethodSpec("parked-kf", "align", "inmotion.align.parked_kf:run_parked_kf", "inmotion.align.parked_kf:ParkedKfConfig", True, "parked (wobbling base) zero-velocity fine alignment, 12-state KF (paper 003 eq. 11-13)"),
    MethodSpec("od-kf", "align", "inmotion.align.aided_kf:run_od_kf", "inmotion.align.aided_kf:AidedKfConfig", True, "SINS / odometer in-motion fine alignment, 21-state KF, velocity or displacement-increment measurement, FDI + NHC fallback (paper 003 eq. 14-26)"),
    MethodSpec("ldv-kf", "align", "inmotion.align.aided_kf:run_ldv_kf", "inmotion.align.aided_kf:AidedKfConfig", True, "SINS / LDV in-motion fine alignment, 21-state KF, velocity or displacement-increment measurement, FDI + NHC fallback (paper 003 eq. 14-26)"),
    MethodSpec("nhc-kf", "align", "inmotion.align.aided_kf:run_nhc_kf", "inmotion.align.aided_kf:NhcKfConfig", True, "vehicle-constraint (NHC, vehicle frame) in-motion fine alignment, 15-state KF (paper 003 eq. 27-31)"),
    MethodSpec("fkf", "align", "inmotion.align.aided_kf:run_fkf", "inmotion.align.aided_kf:FkfConfig", True, "federated OD / LDV Kalman filter with chi-square FDI and Table 1 reconfiguration (paper 003 sec. 3.1-3.2)"),
    MethodSpec("fine-mux", "align", "inmotion.align.multiplex:run_fine_mux", "inmotion.align.multiplex:MuxConfig", False, "fault-tolerant inertial-frame coarse, then fine alignment from the window's start (information multiplexing, paper 003 sec. 3.2.1, 3.3.1)"),
    MethodSpec("adaptive", "align", "inmotion.align.strategy:run_adaptive", "inmotion.align.strategy:AdaptiveConfig", False, "adaptive strategy: parked/moving chi-square detection, parked coarse + parked-kf or in-motion coarse + fine (paper 003 sec. 3.3.2)"),
]


def methods(kind: str | None = None) -> list[MethodSpec]:
    """All registered methods (of one kind if given), in registration order."""
    return [s for s in _SPECS if kind is None or s.kind == kind]


def get(name: str) -> MethodSpec:
    for s in _SPECS:
        if s.name == name:
            return s
    raise KeyError(f"unknown method {name!r}; known: {', '.join(s.name for s in _SPECS)}")


def register(spec: MethodSpec) -> MethodSpec:
    """Add a method defined outside the package (its ``entry`` and ``config`` point at any
    importable module, e.g. ``f"{__name__}:run_mine"``); ``inmotion.run`` then finds it by
    name. Raises ``ValueError`` if the name is taken or not lower-case hyphenated."""
    if not spec.name or spec.name != spec.name.lower() or " " in spec.name:
        raise ValueError(f"a method name is lower-case and hyphenated, got {spec.name!r}")
    if any(s.name == spec.name for s in _SPECS):
        raise ValueError(f"a method named {spec.name!r} is already registered")
    if spec.kind not in ("align", "navigate"):
        raise ValueError(f"kind must be 'align' or 'navigate', got {spec.kind!r}")
    _SPECS.append(spec)
    return spec


# --------------------------------------------------------------------------- sensors

#: the forward-velocity sensors a bundle may hold, in the order ``sensor: auto`` prefers them
#: where a method does not say otherwise
SPEED_SENSORS = ("radar", "ldv", "odometer")
_ANY_SPEED = SPEED_SENSORS

#: method -> what it needs beyond the IMU: a tuple of alternatives, each of which must be met
#: by one sensor of the bundle (``()``: the IMU alone). With the default ``sensor: auto`` a
#: method picks among the sensors present; an explicitly chosen sensor that is absent is the
#: method's own error.
REQUIRES: dict[str, tuple[tuple[str, ...], ...]] = {
    "sins": (), "parked-kf": (), "nhc-kf": (), "coarse-inertial": (),
    "dr": (_ANY_SPEED,), "sins-dr": (_ANY_SPEED,), "dr-kf": (_ANY_SPEED,),
    "od-velocity-kf": (_ANY_SPEED,), "imada-vb": (_ANY_SPEED,), "imada-vn": (_ANY_SPEED,),
    "imada-dual": (_ANY_SPEED,), "mimada": (_ANY_SPEED,), "mimada-dual": (_ANY_SPEED,),
    "oba": (_ANY_SPEED,), "usque": (_ANY_SPEED,), "ausque": (_ANY_SPEED,),
    "usque-hinf": (_ANY_SPEED,), "ausquhe": (_ANY_SPEED,),
    "od-kf": (("odometer",),), "ldv-kf": (("ldv",),), "fkf": (("odometer",), ("ldv",)),
    "fine-mux": (("odometer", "ldv"),), "adaptive": (("odometer", "ldv"),),
}


def present_sensors(bundle) -> list[str]:
    """The aiding tables the bundle holds with at least one row (velocity sensors, ``baro``)."""
    out = []
    for name in SPEED_SENSORS + ("baro",):
        x = getattr(bundle, name, None)
        if x is not None and len(getattr(x, "t", ())) > 0:
            out.append(name)
    return out


def _present(bundle_or_names) -> set[str]:
    if isinstance(bundle_or_names, (set, frozenset, list, tuple)):
        return set(bundle_or_names)
    return set(present_sensors(bundle_or_names))


def missing_sensors(name: str, bundle_or_names) -> list[str]:
    """What the method ``name`` needs that the bundle (or a collection of sensor names) lacks,
    one entry per unmet need (``"odometer"``, ``"radar, ldv or odometer"``); ``[]`` if it can
    run."""
    have = _present(bundle_or_names)
    out = []
    for alts in REQUIRES.get(name, ()):
        if not have.intersection(alts):
            out.append(alts[0] if len(alts) == 1 else
                       ", ".join(alts[:-1]) + f" or {alts[-1]}")
    return out


def runnable(bundle_or_names, kind: str | None = None) -> list[str]:
    """The methods (of one kind if given) whose sensor needs the bundle meets, in registration
    order."""
    have = _present(bundle_or_names)
    return [s.name for s in methods(kind) if not missing_sensors(s.name, have)]


def check_sensors(name: str, bundle) -> None:
    """``BadInput`` if the method ``name`` cannot run on ``bundle``'s sensors: what is missing
    and which methods of the same kind can run instead."""
    miss = missing_sensors(name, bundle)
    if not miss:
        return
    from .errors import BadInput
    have = present_sensors(bundle)
    kind = get(name).kind
    alt = runnable(bundle, kind)
    other = runnable(bundle, "navigate" if kind == "align" else "align")
    raise BadInput(
        f"{name} needs {' and '.join(miss)}, but bundle {getattr(bundle, 'name', '?')!r} has "
        f"{', '.join(have) if have else 'no aiding sensor (IMU only)'}; {kind} methods that "
        f"can run on it: {', '.join(alt) or 'none'}"
        + (f" (and {'navigate' if kind == 'align' else 'align'}: {', '.join(other)})"
           if other else "") + "; or 'inmotion process' picks the stages itself")


def sensors_used(info: dict) -> list[str]:
    """The sensors a method's ``info`` says it used (``sensors``, ``sensor``,
    ``velocity_sensor``), as a list (empty when it says none)."""
    for key in ("sensors_used", "sensors", "velocity_sensor", "sensor"):
        v = info.get(key)
        if isinstance(v, str) and v:
            return [v]
        if isinstance(v, (list, tuple)) and all(isinstance(x, str) for x in v) and v:
            return list(v)
    return []
