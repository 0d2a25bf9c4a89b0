"""Sensor faults in time windows (scenario ``faults:``), applied to a sensor's samples.

A fault acts on the samples with ``start_s <= t < end_s``. Two stages, because for the odometer
some faults change what the wheel does (before pulse counting) and some what the line carries:

- :func:`apply_value_faults` changes values: ``offset``, ``scale``, ``outliers``, ``slip``,
  ``idle``. For distance outputs (``ds`` over the sample period ``T``) a speed-like amount ``x``
  [m/s] becomes ``x * T`` [m] per sample.
- :func:`apply_stream_faults` changes the stream: ``stuck`` (each sample in the window repeats the
  last value before it; at the very start, the first sample's value) and ``dropout`` (samples in
  the window removed; the distance they carried is lost).

Each applied fault is described in :func:`describe` for ``meta.yaml``.
"""
from __future__ import annotations

import numpy as np

__all__ = ["apply_value_faults", "apply_stream_faults", "describe", "VALUE_KINDS",
           "STREAM_KINDS"]

VALUE_KINDS = ("offset", "scale", "outliers", "slip", "idle")
STREAM_KINDS = ("stuck", "dropout")


def _window(t, f):
    return (t >= f.start_s) & (t < f.end_s)


def apply_value_faults(t, values, faults, *, period_s=None, rng=None):
    """``values`` (new array) with the value-changing faults applied.

    Parameters
    ----------
    t : (N,) sample times [s];  values : (N,) speed [m/s], distance increment [m] or height [m]
    faults : the scenario's Fault entries for this sensor (others are skipped)
    period_s : sample period [s] if ``values`` are distance increments, else None
    rng : numpy.random.Generator, for outliers
    """
    out = np.array(values, dtype=float)
    per = 1.0 if period_s is None else period_s
    for f in faults:
        if f.kind not in VALUE_KINDS:
            continue
        m = _window(t, f)
        if f.kind == "offset":
            out[m] += (f.offset_m if f.sensor == "baro" else f.offset_m_s * per)
        elif f.kind == "scale":
            out[m] *= 1.0 + f.scale_ppm * 1e-6
        elif f.kind == "slip":
            out[m] *= 1.0 + f.slip_ratio
        elif f.kind == "idle":
            out[m] += f.idle_speed_m_s * per
        else:  # outliers
            mag = f.magnitude_m if f.sensor == "baro" else f.magnitude_m_s * per
            idx = np.flatnonzero(m)
            hit = idx[rng.random(len(idx)) < f.probability]
            out[hit] += rng.uniform(-mag, mag, len(hit))
    return out


def apply_stream_faults(t, values, faults):
    """``(t, values)`` with ``stuck`` and ``dropout`` applied (new arrays)."""
    values = np.array(values, dtype=float)
    keep = np.ones(len(t), dtype=bool)
    for f in faults:
        m = _window(t, f)
        if f.kind == "stuck" and m.any():
            first = int(np.argmax(m))
            values[m] = values[max(first - 1, 0)]
        elif f.kind == "dropout":
            keep &= ~m
    return np.asarray(t)[keep], values[keep]


def describe(f) -> dict:
    """A fault as a plain dict in human units (for meta.yaml)."""
    return {k: v for k, v in f.model_dump().items() if v is not None}
