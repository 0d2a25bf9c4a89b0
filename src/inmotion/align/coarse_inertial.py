"""Inertial-frame coarse alignment, parked on a wobbling base or in motion (paper 003 eq. 1-10).

Paper 003 decomposes ``C_b^n = C_{i0}^n C_{ib0}^{i0} C_b^{ib0}`` (eq. 1): ``i0`` is the Earth
frame frozen at the start, ``ib0`` the body frame frozen at the start (``= b(0)``).
``C_{i0}^n(t) = C_e^n(L, lambda) C_{i0}^e(t)`` is known in closed form from the position and
the Earth's rotation (eq. 2-3), ``C_b^{ib0}`` follows the gyros (eq. 4), and the constant
``C_{ib0}^{i0}`` maps the gravity vectors seen by the accelerometers in ``ib0`` onto those
known in ``i0`` (eq. 6-9). Since ``C_{n(t)}^{n(0)} = C_e^{n(0)} C_{i0}^{n(t)T}`` this is the same
constant as paper 004's ``C_b^n(0)`` up to the known ``C_e^{n(0)}``, so the machinery of
:mod:`inmotion.align.obs_vectors` (with :data:`~inmotion.align.obs_vectors.NAV_CLOSED`) serves,
and the method reports ``C_b^n(0)`` and ``C_b^n(t)`` like the IMADA family.

* Integrated, multi-vector form: instead of two instantaneous gravity vectors (eq. 9, which are
  differentiated accelerometer data, hence noisy) the vectors are the integrals
  ``alpha(t) = int g^{ib0} dt`` and ``beta(t) = int C_n^{i0} g^n dt`` at every interval, all
  fused by Davenport's q-method (eq. 9's dual-vector TRIAD, :func:`inmotion.estimation.qmethod.triad`,
  is the two-vector special case).
* Low-pass filtering against engine vibration: a first-order low-pass of time constant
  ``lowpass_time_constant_s`` applied identically to ``alpha`` and ``beta``. Because ``C`` is
  constant, a linear time-invariant filter of both sequences keeps ``C alpha_f = beta_f``
  exactly, while vibration in ``alpha`` is attenuated.
* Centred vectors (on by default): the velocity of the base's linear vibration at ``t0`` (or the
  error of ``v^b(0)`` in motion) is a constant offset of every ``alpha``; the centred q-method
  removes it (:func:`inmotion.estimation.qmethod.k_centered`).
* In motion (eq. 7 with eq. 10): ``g^{ib0} = d/dt v^{ib0} + omega_ie^{ib0} x v^{ib0} - C_b^{ib0}
  f^b`` with ``v^{ib0} = C_b^{ib0} v^b`` from the odometer/LDV/radar; the Earth-rate term
  needs ``C_{i0}^{ib0}`` and uses the running answer. The position in ``C_{i0}^n(t)`` comes from
  dead reckoning with the running answer (sec. 2.2: "the carrier displacement").

Theoretical limits (parked, after the vectors span enough Earth rotation): level error
``|phi_E|, |phi_N| <= |nabla| / g`` (accelerometer bias), heading error
``|phi_U| ~ |eps_E| / (omega_ie cos L) + |nabla_E| tan L / g`` (gyro drift), where the East
component is the bias or drift resolved in ``n``.
"""
from __future__ import annotations

import functools
from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field

from .. import config_fields as cf
from ..core.bundle import Bundle
from ..core.solution import NavState
from . import attitude_determination as ad
from . import obs_vectors as ov

__all__ = ["CoarseInertialConfig", "run_coarse_inertial"]


class CoarseInertialConfig(BaseModel):
    """Configuration of the inertial-frame coarse alignment (human units)."""

    model_config = ConfigDict(extra="forbid")

    mode: Literal["auto", "parked", "moving"] = Field(
        "auto", description="parked: no velocity sensor used (zero velocity); moving: needs "
                            "one; auto: moving if the bundle has a velocity sensor")
    velocity_sensor: Optional[Literal["radar", "ldv", "odometer"]] = cf.velocity_sensor(None)
    lowpass_time_constant_s: Optional[float] = Field(1.0, gt=0.0, le=60.0,
                                                     description="low-pass of the vectors; None: off")
    center_vectors: bool = Field(
        True,
        description="q-method on centred vectors: a constant offset (error of v^b(0), base "
                    "vibration) is estimated away")
    initial_speed_fit_s: float = Field(
        1.0, ge=0.0, le=30.0,
        description="line fit of v^b(0) over this window [s]; 0: raw sample (paper)")
    update_interval_s: float = Field(
        0.1, gt=0.0, le=60.0,
        description="re-solve the running q-method answer this often [s]")
    output_interval_s: float = Field(
        1.0, gt=0.0, le=600.0, description="spacing of the output rows [s]")
    min_window_s: float = Field(10.0, ge=0.0, description="shortest window accepted [s]")


def run_coarse_inertial(bundle: Bundle, config: CoarseInertialConfig,
                        init: Optional[NavState] = None, progress=None,
                        error_map: bool = False):
    """Inertial-frame coarse alignment (paper 003 eq. 1-10); returns the attitude series, the
    attitude at the start and end of the window and the q-method's eigenvalue gap.
    ``error_map``: return ``(solution, map)`` with the linear map from a body-velocity error
    to the attitude error (:func:`inmotion.align.attitude_determination.window_error_map`;
    in motion only, else None), from which ``fine-mux`` sizes its window's terms."""
    moving = config.mode == "moving" or (
        config.mode == "auto" and any(getattr(bundle, s) is not None
                                      for s in ("radar", "ldv", "odometer")))
    inp = ad.prepare(bundle, init, sensor=config.velocity_sensor, moving=moving,
                     min_window_s=config.min_window_s, v0_fit_s=config.initial_speed_fit_s)
    model = ov.MODEL_VB_EARTH if moving else ov.MODEL_VB
    lev = ad.run_level(inp, model, nav=ov.NAV_CLOSED, centered=config.center_vectors,
                       update_interval_s=config.update_interval_s,
                       output_interval_s=config.output_interval_s,
                       lowpass_time_constant_s=config.lowpass_time_constant_s)
    name = "coarse-inertial-moving" if moving else "coarse-inertial-parked"
    # in motion the window's own terms join the envelope (issue 15, session 24); the map is
    # made once, where asked for (``error_map``) or an envelope is reported
    emap = functools.cache(lambda: ad.window_error_map(inp, lev, config.lowpass_time_constant_s))
    window = None
    if moving:
        from .multiplex import standalone_window_envelope
        window = standalone_window_envelope(bundle, inp, emap)
    sol = ad.to_solution(inp, lev, method="coarse-inertial", config=config,
                         levels_info=[ad.level_info(lev, name)],
                         meta=bundle.meta, window_envelope=window)
    return (sol, emap() if moving else None) if error_map else sol

