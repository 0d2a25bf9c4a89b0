"""In-motion attitude determination alignment (IMADA) and its multistage forms (paper 004),
and the optimization-based alignment's q-method (OBA, paper 001 eq. 12-19).

Every method decomposes ``C_b^n(t) = C_{n(t)}^{n(0)T} C_b^n(0) C_{b(t)}^{b(0)}`` and finds the
constant ``C_b^n(0)`` by the recursive Davenport q-method from vector pairs integrated by
:mod:`inmotion.align.obs_vectors`. They need no initial attitude (``init`` gives only the
position) and a forward-velocity sensor (radar, LDV or odometer).

========================  ======================================================================
method                    vectors
========================  ======================================================================
``imada-vb``              paper 004 eq. 9: ``V^b``-aided, ``omega_ie^b x V^b`` dropped; ``v^n``
                          (transport rate, position) from the running answer
``imada-vn``              paper 004 eq. 10: ``V^n``-aided, ``v^n`` from the running answer
``imada-dual``            paper 004 eq. 19: dual velocity modelling, running answer
``mimada``                paper 004 sec. 2.2: level 1 ``imada-vb``, levels 2..s ``imada-vn`` with
                          the previous level's ``C_b^n(0)`` for ``v^n``
``mimada-dual``           paper 004 sec. 3: level 1 ``imada-vb``, levels 2..s ``imada-dual``
``oba``                   paper 001 eq. 13 and 19: ``alpha`` keeps ``int C (omega_ie^b x v^b)``,
                          accumulated with the running answer
========================  ======================================================================

Error-free bounds (derived for a straight, level, constant-velocity drive of speed ``v`` at
latitude ``L``; the tests check them on analytic drives):

* ``imada-vb`` omits ``delta_alpha(t) = int C_{b}^{b(0)} (omega_ie^b x V^b) dt``. Mapped to
  ``n(0)`` it is ``int C_{n(t)}^{n(0)} w dt = w t + (omega_in x w) t^2 / 2 + ...`` with
  ``w = omega_ie^n x v^n = [-W sL vN, W sL vE, -W cL vE]`` (``W = omega_ie``). Against
  ``alpha``'s vertical part ``g t`` the horizontal ``w t`` is a tilt: level error
  ``omega_ie sin L |v| / g`` (1.1e-4 rad = 22 arcsec at 20 m/s, 45.7 deg N). The ``t^2`` part,
  North component ``-omega_ie^2 sin^2 L vN / 2``, has the form of the heading signal
  ``g omega_ie cos L t^2 / 2`` (East), so the heading error is
  ``omega_ie sin^2 L |vN| / (g cos L) <= omega_ie sin L tan L |v| / g`` (19 arcsec at 20 m/s;
  the tests allow 1.5 times this). On a manoeuvring drive ``w`` turns with the track and is no
  longer absorbed as a tilt: error-free heading errors of 0.4-0.5 deg appear in 120 s segments
  with a turn or an acceleration from rest (measured, ``reproduce_004``).
* ``imada-dual``, ``imada-vn``, ``oba`` with the true ``C_b^n(0)`` for ``v^n``: exact up to the
  two-sample discretization (< 1e-7 rad measured). With the running answer instead (the
  single-level methods) the early answer's heading error ``dpsi`` mis-rotates ``v^n``; frozen
  into ``int omega_ie^n x v^n`` (dual, vn) it costs up to ~0.1 deg at 20 m/s and degrees at
  80 m/s: these models are meant for the higher levels of a multistage alignment.
* Multistage (level ``k >= 2`` uses level ``k-1``'s ``C_b^n(0)`` for ``v^n``): the previous
  heading error rotates ``v^n``, hence the transport rate, by ``|v| dpsi / R``, a drift whose
  heading effect is at most ``|v| dpsi / (R omega_ie cos L)``: ``dpsi_k <= G dpsi_{k-1}`` with
  ``G = |v| / (R omega_ie cos L)`` (0.06 at 20 m/s, 0.25 at 80 m/s), and no tilt from an omitted
  term.

Improvements over the paper, both on by default, both switchable off to reproduce it
(``center_vectors=False, initial_speed_fit_s=0``):

* ``v^b(0)`` enters every ``alpha`` as the same constant, so its noise (0.03 m/s in paper 004's
  simulation) is not averaged by the q-method and dominates the heading error of a 120 s
  alignment: against the heading signal ``g omega_ie cos L t^2 / 2`` (3.6 m/s at 120 s) a
  0.026 m/s error along North costs about ``(5/3) 0.026 / 3.6`` rad = 0.7 deg for equal weights.
  ``center_vectors`` solves Wahba's problem for the centred vectors, which estimates any
  constant offset of ``alpha`` away (:func:`inmotion.estimation.qmethod.k_centered`);
* ``v^b(0)`` is a line fit over the first ``initial_speed_fit_s`` seconds rather than one sample
  (:mod:`inmotion.align.velocity_source`), which also helps the running answer early on.
"""
from __future__ import annotations

from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field

from ..core.bundle import Bundle
from ..core.solution import NavState, Solution
from . import attitude_determination as ad
from . import obs_vectors as ov

__all__ = ["ImadaConfig", "MimadaConfig", "run_imada_vb", "run_imada_vn", "run_imada_dual",
           "run_mimada", "run_mimada_dual", "run_oba"]

SensorName = Optional[Literal["radar", "ldv", "odometer"]]

_MODEL_NAMES = {ov.MODEL_VB: "imada-vb", ov.MODEL_VN: "imada-vn", ov.MODEL_DUAL: "imada-dual",
                ov.MODEL_VB_EARTH: "oba"}


class ImadaConfig(BaseModel):
    """Configuration of a single-level attitude-determination alignment (human units)."""

    model_config = ConfigDict(extra="forbid")

    velocity_sensor: SensorName = Field(None, description="radar, ldv or odometer; None: first present")
    initial_speed_fit_s: float = Field(1.0, ge=0.0, le=30.0,
                                       description="line fit of v^b(0) over this window; 0: raw sample (paper)")
    update_interval_s: float = Field(0.1, gt=0.0, le=60.0,
                                     description="re-solve the running q-method answer this often")
    output_interval_s: float = Field(1.0, gt=0.0, le=600.0, description="attitude series spacing")
    fading_time_constant_s: Optional[float] = Field(None, gt=0.0,
                                                    description="K fades with this time constant; None: no fading")
    min_window_s: float = Field(10.0, ge=0.0, description="shortest window accepted")
    center_vectors: bool = Field(True, description="q-method on centred vectors: a constant "
                                 "offset of alpha (the error of v^b(0)) is estimated away; "
                                 "False: the paper's form")


class MimadaConfig(ImadaConfig):
    """Multistage: ``levels`` passes, the first ``imada-vb`` (paper 004: 2 levels)."""

    levels: int = Field(
        2, ge=2, le=10,
        description="number of passes, the first one imada-vb (paper 004: 2)")


def _single(bundle, config, init, model, method) -> Solution:
    inp = ad.prepare(bundle, init, sensor=config.velocity_sensor, moving=True,
                     min_window_s=config.min_window_s, v0_fit_s=config.initial_speed_fit_s)
    lev = ad.run_level(inp, model, **_level_kw(config))
    return _solution(bundle, inp, lev, config, method, [ad.level_info(lev, _MODEL_NAMES[model])])


#: the final level's vector models whose answer :func:`~inmotion.align.
#: attitude_determination.window_error_map` linearises (issue 15, session 24, checked by
#: finite differences on paper 003's drive, windows 60 / 120 / 300 s, a 30 arcmin yaw
#: mounting's heading: imada-vb 400 / -35 / -18.2 arcmin against the map's 392 / -46 /
#: -18.1; imada-dual, oba and mimada-dual alike; pitch within 0.2 arcmin). Not ``MODEL_VN``
#: (imada-vn, mimada): its ``v^n`` from the running answer takes the mounting another way
#: (finite difference 233-410 arcmin against the map's -29), so their envelope keeps the
#: IMU's terms only, with a warning (120 s windows of paper 003's drive, seeds 3-8: heading
#: 4-41 arcmin mimada, 57-162 imada-vn, against 1.5; the others, with the window's terms, a
#: mean (e / sigma)^2 of 0.09-0.18 at a 46-47 arcmin envelope)
WINDOW_MAP_MODELS = (ov.MODEL_VB, ov.MODEL_DUAL, ov.MODEL_VB_EARTH)


def _solution(bundle, inp, lev, config, method, levels_info) -> Solution:
    """:func:`~inmotion.align.attitude_determination.to_solution` of the final level, its
    envelope with the window's own terms (:func:`inmotion.align.multiplex.
    standalone_window_envelope`) where the error map holds: a final level of
    :data:`WINDOW_MAP_MODELS`, centred vectors (the map's derivation) and no fading memory
    (its weights); elsewhere the IMU's terms, and a warning says so."""
    from .multiplex import standalone_window_envelope
    mapped = (lev.model in WINDOW_MAP_MODELS and config.center_vectors
              and not config.fading_time_constant_s)
    window = (standalone_window_envelope(bundle, inp, lambda: ad.window_error_map(inp, lev))
              if mapped else None)
    sol = ad.to_solution(inp, lev, method=method, config=config, levels_info=levels_info,
                         meta=bundle.meta, window_envelope=window)
    if not mapped and sol.info.get("envelope") is not None:
        sol.info["envelope"]["window"] = None
        sol.info["warnings"] = [*(sol.info.get("warnings") or []), (
            f"{sol.info.get('method')}: the envelope holds the IMU's terms only: the "
            "window's (the IMU's mounting, the speed's scale factor and lever arm, the "
            "vehicle constraint's violation) are not linearised for these vectors (V^n from "
            "the running answer, or uncentred / fading ones); on paper 003's simulated drive "
            "(120 s) imada-vn and mimada ended 4-162 arcmin off in heading against its 1.5. "
            "For an envelope that holds them use imada-vb, imada-dual, mimada-dual, oba or "
            "coarse-inertial")]
    return sol


def _level_kw(config) -> dict:
    return dict(centered=config.center_vectors, update_interval_s=config.update_interval_s,
                output_interval_s=config.output_interval_s,
                fading_time_constant_s=config.fading_time_constant_s)


def _multistage(bundle, config, init, high_model, method, progress) -> Solution:
    inp = ad.prepare(bundle, init, sensor=config.velocity_sensor, moving=True,
                     min_window_s=config.min_window_s, v0_fit_s=config.initial_speed_fit_s)
    lev = ad.run_level(inp, ov.MODEL_VB, **_level_kw(config))
    info = [ad.level_info(lev, "imada-vb")]
    for k in range(2, config.levels + 1):
        if progress is not None:
            progress((k - 1) / config.levels)
        C0 = lev.C0
        del lev                   # its series (one row a second) go before the next level's
        lev = ad.run_level(inp, high_model, C_fixed=C0, **_level_kw(config))
        info.append(ad.level_info(lev, _MODEL_NAMES[high_model]))
    if progress is not None:
        progress(1.0)
    return _solution(bundle, inp, lev, config, method, info)


def run_imada_vb(bundle: Bundle, config: ImadaConfig, init: Optional[NavState] = None,
                 progress=None) -> Solution:
    """Traditional ``V^b``-aided IMADA (paper 004 eq. 1-9)."""
    return _single(bundle, config, init, ov.MODEL_VB, "imada-vb")


def run_imada_vn(bundle: Bundle, config: ImadaConfig, init: Optional[NavState] = None,
                 progress=None) -> Solution:
    """``V^n``-aided IMADA (paper 004 eq. 10), ``v^n`` from the running answer."""
    return _single(bundle, config, init, ov.MODEL_VN, "imada-vn")


def run_imada_dual(bundle: Bundle, config: ImadaConfig, init: Optional[NavState] = None,
                   progress=None) -> Solution:
    """Dual velocity-modelling IMADA (paper 004 eq. 11-19), running answer for ``v^n``."""
    return _single(bundle, config, init, ov.MODEL_DUAL, "imada-dual")


def run_oba(bundle: Bundle, config: ImadaConfig, init: Optional[NavState] = None,
            progress=None) -> Solution:
    """Optimization-based alignment vectors with the Earth-rate term kept (paper 001 eq. 12-19),
    solved by the q-method (the coarse OBA that paper 001's filter starts from)."""
    return _single(bundle, config, init, ov.MODEL_VB_EARTH, "oba")


def run_mimada(bundle: Bundle, config: MimadaConfig, init: Optional[NavState] = None,
               progress=None) -> Solution:
    """Traditional multistage IMADA: ``imada-vb``, then ``imada-vn`` levels (paper 004 sec. 2.2)."""
    return _multistage(bundle, config, init, ov.MODEL_VN, "mimada", progress)


def run_mimada_dual(bundle: Bundle, config: MimadaConfig, init: Optional[NavState] = None,
                    progress=None) -> Solution:
    """Improved multistage IMADA: ``imada-vb``, then ``imada-dual`` levels (paper 004 sec. 3)."""
    return _multistage(bundle, config, init, ov.MODEL_DUAL, "mimada-dual", progress)
