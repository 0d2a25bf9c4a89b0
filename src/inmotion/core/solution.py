"""What a method starts from (:class:`NavState`) and what it returns (:class:`Solution`).

All SI: latitude and longitude in rad, height in m, velocity ENU in m/s, Euler angles
``[pitch, roll, yaw]`` in rad. Files and reports convert at the edge (``inmotion.io``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import rotations
from .bundle import row_at_or_after

__all__ = ["NavState", "Solution", "StateUnit"]


@dataclass
class NavState:
    """A navigation state at time ``t``: position, ENU velocity and attitude ``q_nb``.

    The quaternion is the one canonical attitude; ``euler`` and ``C_nb`` are derived.
    """

    t: float
    lat: float
    lon: float
    h: float
    vel_n: np.ndarray
    q_nb: np.ndarray

    def __post_init__(self):
        self.vel_n = np.array(self.vel_n, dtype=float).reshape(3)
        self.q_nb = rotations.quat_normalize(np.array(self.q_nb, dtype=float).reshape(4))

    @classmethod
    def from_euler(cls, t, lat, lon, h, vel_n, euler) -> "NavState":
        return cls(float(t), float(lat), float(lon), float(h), vel_n,
                   rotations.quat_from_euler(np.asarray(euler, dtype=float)))

    @classmethod
    def from_truth(cls, truth, t=None, euler_error=(0.0, 0.0, 0.0)) -> "NavState":
        """The truth row at or after ``t`` [s] (default: the first row), with ``euler_error``
        = ``[pitch, roll, yaw]`` [rad] added to its attitude: how ``--init truth --init-error``,
        the campaigns, reproductions and benchmarks start a method from a
        :class:`~inmotion.core.bundle.Truth`."""
        row = truth.at(truth.t[0] if t is None else t)
        return cls.from_euler(row["t"], row["lat"], row["lon"], row["h"], row["vel_n"],
                              row["euler"] + np.asarray(euler_error, dtype=float))

    @property
    def euler(self) -> np.ndarray:
        return rotations.euler_from_quat(self.q_nb)

    @property
    def C_nb(self) -> np.ndarray:
        return rotations.dcm_from_quat(self.q_nb)

    def copy(self) -> "NavState":
        return NavState(self.t, self.lat, self.lon, self.h, self.vel_n.copy(), self.q_nb.copy())


@dataclass(frozen=True)
class StateUnit:
    """How an estimated state is written at the edge: ``value_in_unit = value_si * scale``."""

    unit: str
    scale: float = 1.0


@dataclass
class Solution:
    """A method's output time series.

    Parameters
    ----------
    t : (N,) s
    lat, lon : (N,) rad;  h : (N,) m
    vel_n : (N, 3) m/s, ENU
    euler : (N, 3) rad, [pitch, roll, yaw]
    sigma : dict name -> (N,) 1-sigma in SI. Names: ``north``, ``east``, ``h`` [m];
        ``vE``, ``vN``, ``vU`` [m/s]; ``phi_E``, ``phi_N``, ``phi_U`` [rad] (misalignment).
    states : dict name -> (N,) estimated state in SI (names from the method's state layout,
        e.g. ``mount_x``, ``dk``, ``eps_x``).
    state_units : dict name -> :class:`StateUnit`, how each state is written to files.
    info : dict, method name, configuration echo (human units), timing, events (e.g. fault
        detections with time and test value), quality figures.
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    vel_n: np.ndarray
    euler: np.ndarray
    sigma: dict = field(default_factory=dict)
    states: dict = field(default_factory=dict)
    state_units: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float)
        n = len(self.t)
        for k in ("lat", "lon", "h"):
            v = np.asarray(getattr(self, k), dtype=float)
            if v.shape != (n,):
                raise ValueError(f"Solution.{k} must have shape ({n},), got {v.shape}")
            setattr(self, k, v)
        for k in ("vel_n", "euler"):
            v = np.asarray(getattr(self, k), dtype=float)
            if v.shape != (n, 3):
                raise ValueError(f"Solution.{k} must have shape ({n}, 3), got {v.shape}")
            setattr(self, k, v)

    def __len__(self):
        return len(self.t)

    @property
    def C_nb(self) -> np.ndarray:
        return rotations.dcm_from_euler(self.euler)

    def final_state(self) -> NavState:
        """The last epoch as a :class:`NavState` (for ``--init RESULT``)."""
        return NavState.from_euler(self.t[-1], self.lat[-1], self.lon[-1], self.h[-1],
                                   self.vel_n[-1], self.euler[-1])

    def state_at(self, t: float) -> NavState:
        """The solution row at or after ``t`` [s] (:func:`inmotion.core.bundle.row_at_or_after`)
        as a :class:`NavState`."""
        i = int(row_at_or_after(self.t, t))
        return NavState.from_euler(self.t[i], self.lat[i], self.lon[i], self.h[i],
                                   self.vel_n[i], self.euler[i])

    @classmethod
    def from_arrays(cls, t, lla, vel_n, q_nb, **kw) -> "Solution":
        """From (N, 3) ``lla`` and (N, 4) ``q_nb`` arrays, as mechanization kernels produce."""
        lla = np.asarray(lla, dtype=float)
        return cls(t, lla[:, 0], lla[:, 1], lla[:, 2], vel_n,
                   rotations.euler_from_quat(np.asarray(q_nb, dtype=float)), **kw)
