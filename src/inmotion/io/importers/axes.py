"""Declared axis conventions: source axes to the body frame b (Right-Forward-Up) and
source attitude conventions to the DESIGN Euler angles.

Importers never guess axes. Each format declares, as a constant, which physical direction
each of its sensor axes points to (``("forward", "right", "down")`` for the KF-GINS and
comma2k19 IMUs), and :func:`C_b_src` turns that declaration into the matrix ``C_b^src``
with ``vec_b = C_b^src @ vec_src``.

Reference attitudes in the aerospace convention (navigation frame North-East-Down, body
Forward-Right-Down, Euler ``yaw-pitch-roll`` in ZYX order, ``C_frd^ned = R_z(yaw) R_y(pitch)
R_x(roll)``) are converted through the direction cosine matrix, never by copying angles:
``C_b^n = C_enu^ned C_frd^ned C_frd^rfu`` and then ``inmotion.core.rotations.euler_from_dcm``.
(With these frames the two Euler sequences describe the same physical rotations, yaw about the
vertical, then pitch about the right axis, then roll about the forward axis, so the angles agree
to rounding; going through the matrix makes that a tested fact rather than an assumption.)
"""
from __future__ import annotations

import numpy as np

from ...core import rotations
from ...errors import BadInput

__all__ = ["AXIS_WORDS", "C_b_src", "C_ENU_NED", "C_RFU_FRD", "FRD",
           "design_euler_from_ned_rpy", "ned_rpy_from_design_euler", "ned_to_enu"]

#: unit vectors in b (Right-Forward-Up) of the words a source may use for its axes
AXIS_WORDS = {
    "right": (1.0, 0.0, 0.0), "left": (-1.0, 0.0, 0.0),
    "forward": (0.0, 1.0, 0.0), "back": (0.0, -1.0, 0.0), "backward": (0.0, -1.0, 0.0),
    "up": (0.0, 0.0, 1.0), "down": (0.0, 0.0, -1.0),
}

#: the Forward-Right-Down axes of KF-GINS, OB_GINS, comma2k19 and the EMS log
FRD = ("forward", "right", "down")


def C_b_src(axes, file=None) -> np.ndarray:
    """``C_b^src`` (3, 3): columns are the source x, y, z axes expressed in b (RFU).

    Parameters
    ----------
    axes : sequence of 3 words from :data:`AXIS_WORDS`, the directions of the source's
        x, y and z axes on the vehicle, e.g. ``("forward", "right", "down")``.
    file : where the declaration came from, for the error message.

    Raises
    ------
    BadInput
        Unknown word, or axes that do not form a right-handed orthonormal triad.
    """
    words = [str(a).strip().lower() for a in axes]
    if len(words) != 3:
        raise BadInput(f"axes must name 3 directions (source x, y, z), got {list(axes)}", file)
    bad = [w for w in words if w not in AXIS_WORDS]
    if bad:
        raise BadInput(f"unknown axis direction {bad[0]!r}; use {', '.join(AXIS_WORDS)}", file)
    C = np.array([AXIS_WORDS[w] for w in words]).T
    if abs(np.linalg.det(C) - 1.0) > 1e-9:
        raise BadInput(f"axes {words} are not a right-handed triad (det = "
                       f"{np.linalg.det(C):+.0f})", file)
    return C


#: FRD to RFU (b): ``vec_rfu = C_RFU_FRD @ vec_frd``
C_RFU_FRD = C_b_src(FRD)
#: ``vec_enu = C_ENU_NED @ vec_ned`` (its own inverse)
C_ENU_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def ned_to_enu(vec_ned) -> np.ndarray:
    """[N, E, D] (..., 3) -> [E, N, U]."""
    vec_ned = np.asarray(vec_ned, dtype=float)
    return vec_ned @ C_ENU_NED.T


def _C_ned_frd(roll, pitch, yaw):
    """``C_frd^ned = R_z(yaw) R_y(pitch) R_x(roll)`` (aerospace ZYX), (N, 3, 3)."""
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    return np.stack([
        np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], -1),
        np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], -1),
        np.stack([-sp, cp * sr, cp * cr], -1)], -2)


def design_euler_from_ned_rpy(roll, pitch, yaw) -> np.ndarray:
    """DESIGN ``[pitch, roll, yaw]`` [rad] (N, 3) from aerospace roll, pitch, yaw [rad].

    Parameters
    ----------
    roll, pitch, yaw : (N,) rad, ``C_src^ned = R_z(yaw) R_y(pitch) R_x(roll)`` with the
        source body axes Forward-Right-Down (KF-GINS ``.nav``, EMS reference).

    Returns
    -------
    (N, 3) ``[pitch, roll, yaw]`` with ``C_b^n = R_z(-yaw) R_x(pitch) R_y(roll)``, b = RFU,
    n = ENU, yaw in [0, 2 pi).
    """
    roll, pitch, yaw = (np.atleast_1d(np.asarray(a, dtype=float)) for a in (roll, pitch, yaw))
    C_ned_frd = _C_ned_frd(roll, pitch, yaw)
    C_nb = C_ENU_NED @ C_ned_frd @ C_RFU_FRD.T
    return rotations.euler_from_dcm(C_nb)


def ned_rpy_from_design_euler(euler) -> np.ndarray:
    """Inverse of :func:`design_euler_from_ned_rpy`: (N, 3) ``[roll, pitch, yaw]`` [rad],
    aerospace ZYX of the FRD body in NED, yaw in [0, 2 pi)."""
    C_nb = rotations.dcm_from_euler(np.atleast_2d(euler))
    C_ned_frd = C_ENU_NED @ C_nb @ C_RFU_FRD
    pitch = np.arcsin(np.clip(-C_ned_frd[..., 2, 0], -1.0, 1.0))
    roll = np.arctan2(C_ned_frd[..., 2, 1], C_ned_frd[..., 2, 2])
    yaw = rotations.wrap_2pi(np.arctan2(C_ned_frd[..., 1, 0], C_ned_frd[..., 0, 0]))
    return np.stack([roll, pitch, yaw], -1)
