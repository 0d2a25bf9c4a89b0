"""Generic plausibility checks of a method's configuration, by field name and value.

Every method configuration is a pydantic model whose fields carry their unit in the name
(``gyro_drift_deg_h``, ``baro_tau_s``, ``lever_arm_m``). :func:`check_config` walks the
validated model (nested mappings and lists too) and refuses, naming the field:

- a number that is NaN or infinite (``--set gyro_drift_deg_h=.inf``, ``sigma0_deg=[.nan,3,12]``);
- a magnitude beyond :data:`MAX_ABS` (1e12) or a non-zero one below :data:`MIN_ABS` (1e-100):
  no unit of this package makes such a value meaningful, and it overflows or divides by zero
  later (``baro_tau_s=1e-300``, ``lever_arm_m=[1e308, 1e308, 0]``);
- a negative noise, sigma, random walk, rate or time constant (names containing ``noise``,
  ``sigma``, ``arw``, ``vrw``, ``_rw_``; names ending ``_hz``, ``_s``);
- a time [s] (a name ending ``_s``, not ``_m_s`` nor ``sqrt_s``) between 0 and 1 ms,
  exclusive (shorter than any IMU period) or above 30 years,
  a rate above 100 kHz or below 1e-6 Hz, a lever arm beyond 100 m, a mounting angle beyond
  30 deg, an angle in degrees beyond 360, a length beyond 1e7 m (the Earth), a speed beyond
  1e4 m/s, a ppm beyond 1e6, arcmin / arcsec beyond a full turn.

It is applied where configurations are validated (``inmotion align/navigate`` via
``build_config``, campaign points via ``inmotion.evaluate.runs``), so the method modules keep
their own declarations and algorithms untouched.
"""
from __future__ import annotations

import math

from .errors import BadInput

__all__ = ["check_config", "check_values", "MAX_ABS", "MIN_ABS"]

MAX_ABS = 1e12
MIN_ABS = 1e-100
#: (field name suffix, largest magnitude, unit): beyond any vehicle or the Earth itself
_UNIT_LIMITS = (("_m_s", 1e4, "m/s"), ("_m", 1e7, "m"), ("_ppm", 1e6, "ppm"),
                ("_arcmin", 21600.0, "arcmin"), ("_arcsec", 1296000.0, "arcsec"))
_NONNEG = ("noise", "sigma", "arw", "vrw", "_rw_")


def _rules(name: str, x: float):
    """The message for field ``name`` holding ``x`` if implausible, else None."""
    if not math.isfinite(x):
        return f"{x} is not a finite number"
    ax = abs(x)
    if ax > MAX_ABS:
        return f"{x:g} is implausibly large (limit {MAX_ABS:g})"
    if 0 < ax < MIN_ABS:
        return f"{x:g} is implausibly small (give 0 or a value above {MIN_ABS:g})"
    low = name.lower()
    if x < 0 and (any(k in low for k in _NONNEG) or low.endswith(("_hz", "_s"))):
        return f"{x:g} must not be negative"
    time = low.endswith("_s") and not low.endswith(("_m_s", "sqrt_s"))   # not m/s, sqrt(s)
    if time and 0 < x < 1e-3:
        return f"{x:g} s is shorter than any IMU period (1 ms)"
    if time and x > 1e9:
        return f"{x:g} s is longer than 30 years"
    rate = low.endswith("_hz") and not low.endswith("sqrt_hz")     # not a noise density
    if rate and x > 1e5:
        return f"{x:g} Hz is above 100 kHz"
    if rate and 0 < x < 1e-6:
        return f"{x:g} Hz is below 1e-6 Hz (a period of 11 days)"
    for suffix, limit, unit in _UNIT_LIMITS:
        if low.endswith(suffix) and ax > limit:
            return f"{x:g} {unit} is beyond {limit:g} {unit}"
    if "lever_arm" in low and low.endswith("_m") and ax > 100.0:
        return f"{x:g} m is not a lever arm on a vehicle (limit 100 m)"
    if "mounting" in low and low.endswith("_arcmin") and ax > 1800.0:
        return f"{x:g} arcmin is beyond 30 deg; degrees given?"
    if low.endswith("_deg") and ax > 360.0:
        return f"{x:g} deg is beyond 360 deg"
    return None


def check_values(data, where: str = "", file=None, name: str = "") -> None:
    """Apply the rules to every number in ``data`` (mappings, lists, numbers); ``where`` is
    the dotted path so far, ``name`` the field the numbers belong to."""
    if isinstance(data, dict):
        for k, v in data.items():
            check_values(v, f"{where}.{k}" if where else str(k), file, str(k))
    elif isinstance(data, (list, tuple)):
        for i, v in enumerate(data):
            check_values(v, f"{where}[{i}]", file, name)
    elif isinstance(data, float) or (isinstance(data, int) and not isinstance(data, bool)):
        msg = _rules(name, float(data))
        if msg:
            raise BadInput(f"{where}: {msg}", file=file)


def check_config(config, method: str, file=None) -> None:
    """Check a validated pydantic configuration of ``method``; :class:`BadInput` naming the
    field at fault (``configuration of 'dr': speed_scale: inf is not a finite number``)."""
    try:
        data = config.model_dump()
    except AttributeError:
        data = dict(config)
    try:
        check_values(data)
    except BadInput as e:
        raise BadInput(f"configuration of {method!r}: {e.what}", file=file) from None
