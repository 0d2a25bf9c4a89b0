"""The forward speed an attitude-determination alignment needs, on the IMU's time base.

The radar and the LDV give speed ``v`` [m/s]; an odometer gives ``v`` or distance increments
``ds`` [m] over the interval ending at ``t``. Distance increments become the mean speed of
their interval, placed at the interval's middle; speeds are interpolated linearly to the IMU
times. The sensor must cover the alignment window (the end values are held over at most one
sensor period, which a distance-increment sensor needs at both ends).

``v^b(0)`` enters every vector of the velocity-aided IMADA with the same sign (paper 004
eq. 9, 19), so its noise is not averaged by the q-method: one 0.03 m/s error costs the whole
alignment. :func:`initial_speed` therefore fits a straight line to the samples of the first
``fit_s`` seconds and evaluates it at ``t0`` (``fit_s = 0``: the raw first sample, as the paper
does). For white noise of standard deviation ``sigma`` and ``m`` samples the line's intercept
has standard deviation ``2 sigma / sqrt(m)`` (least-squares intercept at the window's end),
e.g. 0.006 m/s instead of 0.03 m/s for 1 s at 100 Hz; the price is the speed's curvature
over the window, ``|a'| fit_s^2 / 12``, negligible for a road vehicle over 1 s.
"""
from __future__ import annotations

import numpy as np

from ..core.bundle import Bundle, SpeedData
from ..errors import BadInput

__all__ = ["speed_on_imu_times", "covering_samples", "initial_speed", "pick_sensor",
           "speed_times"]


def pick_sensor(bundle: Bundle, which: str | None) -> tuple[str, SpeedData]:
    """The named velocity sensor or the first of radar, LDV, odometer; ``BadInput`` if none."""
    try:
        return bundle.velocity_sensor(which)
    except ValueError as e:
        raise BadInput(f"{e}; an in-motion alignment needs a forward-velocity sensor "
                       "(radar, ldv or odometer)") from None


def _samples(name: str, sensor: SpeedData) -> tuple[np.ndarray, np.ndarray]:
    """Sample times [s] and speeds [m/s] of the sensor (``ds`` -> mid-interval mean speed)."""
    if sensor.v is not None:
        t, v = sensor.t, sensor.v
    else:
        if len(sensor.t) < 2:
            raise BadInput("needs at least two distance increments", file=name)
        t = speed_times(sensor)[1:]
        v = sensor.speed()[1:]
    bad = ~np.isfinite(v)
    if bad.any():
        i = int(np.argmax(bad))
        raise BadInput("speed is not a finite number", file=name, row=i + 1, time=float(t[i]))
    return t, v


def speed_times(sensor: SpeedData) -> np.ndarray:
    """The times [s] at which ``sensor.speed()`` holds: the sample times for speeds, for
    distance increments the middle of each one's interval (the first sample's speed is its
    next interval's mean, :meth:`~inmotion.core.bundle.SpeedData.speed`, so it is placed
    there too). At the interval's end the mean speed of an accelerating vehicle lags by
    ``a T / 2`` (issue 15, session 25: 2.5 mm/s at 0.5 m/s^2 and 100 Hz, which turned
    ``usque``'s heading by 1-9 arcmin on paper 003's drive)."""
    t = np.asarray(sensor.t, float)
    if sensor.v is not None or len(t) < 2:
        return t
    dt = np.diff(t)
    return np.concatenate([t[:1] + 0.5 * dt[:1], t[1:] - 0.5 * dt])


def speed_on_imu_times(name: str, sensor: SpeedData, t_imu: np.ndarray) -> np.ndarray:
    """Forward speed [m/s] at the IMU times, linear interpolation; ``BadInput`` if the sensor
    does not cover ``[t_imu[0], t_imu[-1]]`` (one sensor period of slack at each end)."""
    t, v = covering_samples(name, sensor, float(t_imu[0]), float(t_imu[-1]))
    return np.interp(t_imu, t, v)


def covering_samples(name: str, sensor: SpeedData, t_first: float,
                     t_last: float) -> tuple[np.ndarray, np.ndarray]:
    """The sensor's sample times [s] and speeds [m/s] (``ds``: mid-interval mean speeds)
    that :func:`speed_on_imu_times` interpolates; ``BadInput`` if they do not cover
    ``[t_first, t_last]`` [s] (one sensor period of slack at each end). ``np.interp`` of them
    at any of the window's times gives :func:`speed_on_imu_times`'s value there."""
    t, v = _samples(name, sensor)
    if len(t) == 0:
        raise BadInput("has no samples", file=name)
    slack = 1.0001 * (float(np.median(np.diff(t))) if len(t) > 1 else 0.0)
    if t[0] > t_first + slack or t[-1] < t_last - slack:
        raise BadInput(f"covers {t[0]:.3f}..{t[-1]:.3f} s but the alignment window is "
                       f"{t_first:.3f}..{t_last:.3f} s", file=name)
    return t, v


def initial_speed(name: str, sensor: SpeedData, t0: float, fit_s: float) -> float:
    """``v^b(0)`` [m/s]: a straight line fitted to the samples in ``[t0, t0 + fit_s]``, at ``t0``
    (``fit_s <= 0`` or fewer than 3 samples: the sample nearest ``t0``)."""
    t, v = _samples(name, sensor)
    m = (t >= t0 - 1e-9) & (t <= t0 + fit_s)
    if fit_s <= 0 or m.sum() < 3:
        return float(np.interp(t0, t, v))
    slope, intercept = np.polyfit(t[m] - t0, v[m], 1)
    return float(intercept)
