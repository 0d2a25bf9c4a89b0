"""Error-state layouts: ordered named blocks of an error-state vector.

A Kalman method never indexes its state with bare numbers. It composes a :class:`Layout`
from named :class:`Block` s (``phi`` 3, ``dv`` 3, ``dp`` 3, ``eps`` 3, ...) and asks it for
slices (``layout["phi"]``), per-element names (``phi_E``, ``mount_x``) used as result
columns, and the display unit of each element (:class:`inmotion.core.solution.StateUnit`).

The catalogue :data:`BLOCKS` fixes, once for the whole package, what each block name means,
its element names and its unit at the edge, so that ``phi`` is the same thing in every method:

=========  ====  ==================================================  ===========
block      size  meaning (SI inside)                                 shown in
=========  ====  ==================================================  ===========
phi        3     SINS misalignment E, N, U [rad] (DESIGN convention) arcmin
dv         3     SINS velocity error E, N, U [m/s]                   m_s
dp         3     SINS position error lat [rad], lon [rad], h [m]     m (N, E, U)
eps        3     gyro drift x, y, z in b [rad/s]                     deg_h
nabla      3     accelerometer bias x, y, z in b [m/s^2]             ug
phi_D      3     dead-reckoning misalignment E, N, U [rad]           arcmin
dp_D       3     dead-reckoning position error lat, lon [rad], h [m] m (N, E, U)
mount      3     velocity-sensor mounting angles about x, y, z [rad] arcmin
dk         1     velocity-sensor scale-factor error [-]              ppm
lever      3     lever arm error x, y, z in b [m]                    m
eps_gm     3     Gauss-Markov part of a constant + GM gyro bias in b deg_h
                 [rad/s] (error_model docstring; issue 15)
=========  ====  ==================================================  ===========

Unit strings are safe in file column names (``states.csv`` writes ``<name>_<unit>``).

Position errors in latitude and longitude are stored in rad (the form of paper 000 eq. 15-21
and of ``Strapdown.correct``); their display unit converts to metres north / east with the
radii at the start of the run, which is what :func:`position_units` gives.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import earth
from ..core.solution import StateUnit

__all__ = ["Block", "Layout", "BLOCKS", "block", "position_units", "KERNEL_BLOCKS",
           "PHI", "DV", "DP", "EPS", "NABLA", "PHI_D", "DP_D", "MOUNT", "DK", "LEVER"]

_ARCMIN = 180.0 / np.pi * 60.0          # rad -> arc-minutes
_DEG_H = 180.0 / np.pi * 3600.0         # rad/s -> deg/h
_UG = 1e6 / earth.G0                    # m/s^2 -> ug


@dataclass(frozen=True)
class Block:
    """A named group of error states.

    Parameters
    ----------
    name : str
        Block name, e.g. ``"phi"``.
    elements : tuple of str
        Element suffixes; element ``i`` is called ``f"{name}_{elements[i]}"``.
    units : tuple of StateUnit
        Display unit of each element (``value_in_unit = value_si * scale``).
    """

    name: str
    elements: tuple
    units: tuple

    @property
    def size(self) -> int:
        return len(self.elements)

    @property
    def names(self) -> tuple:
        if self.size == 1 and self.elements[0] == "":
            return (self.name,)
        return tuple(f"{self.name}_{e}" for e in self.elements)


def _uniform(name, elements, unit):
    return Block(name, tuple(elements), tuple(unit for _ in elements))


#: the catalogue of blocks shared by every Kalman method
BLOCKS = {
    "phi": _uniform("phi", "ENU", StateUnit("arcmin", _ARCMIN)),
    "dv": _uniform("dv", "ENU", StateUnit("m_s", 1.0)),
    "dp": Block("dp", ("lat", "lon", "h"),
                (StateUnit("rad", 1.0), StateUnit("rad", 1.0), StateUnit("m", 1.0))),
    "eps": _uniform("eps", "xyz", StateUnit("deg_h", _DEG_H)),
    "nabla": _uniform("nabla", "xyz", StateUnit("ug", _UG)),
    "phi_D": _uniform("phi_D", "ENU", StateUnit("arcmin", _ARCMIN)),
    "dp_D": Block("dp_D", ("lat", "lon", "h"),
                  (StateUnit("rad", 1.0), StateUnit("rad", 1.0), StateUnit("m", 1.0))),
    "mount": _uniform("mount", "xyz", StateUnit("arcmin", _ARCMIN)),
    "dk": Block("dk", ("",), (StateUnit("ppm", 1e6),)),
    "lever": _uniform("lever", "xyz", StateUnit("m", 1.0)),
    "eps_gm": _uniform("eps_gm", "xyz", StateUnit("deg_h", _DEG_H)),
}


#: the blocks a numba kernel can address, in the order of :meth:`Layout.offsets` (``eps_gm``
#: is not among them: no measurement or feedback addresses it; the error model's ``F`` finds
#: it through ``error_model._offsets``)
KERNEL_BLOCKS = ("phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D", "mount", "dk", "lever")
#: named indices into :meth:`Layout.offsets` (``offs[PHI]`` is the first state of ``phi``, -1
#: when the layout lacks it): how kernels and measurement fills address the state vector,
#: never by bare numbers (KF-GINS's ``StateID`` enum, here derived from the layout)
PHI, DV, DP, EPS, NABLA, PHI_D, DP_D, MOUNT, DK, LEVER = range(len(KERNEL_BLOCKS))


def block(name: str) -> Block:
    """The catalogue block ``name`` (KeyError listing the known names otherwise)."""
    try:
        return BLOCKS[name]
    except KeyError:
        raise KeyError(f"unknown state block {name!r}; known: {', '.join(BLOCKS)}") from None


def position_units(lat0: float, h0: float = 0.0) -> dict:
    """Display units turning lat/lon errors [rad] into metres north / east at ``lat0`` [rad].

    Returns a dict element-name -> :class:`StateUnit` for ``dp_lat``, ``dp_lon``,
    ``dp_D_lat``, ``dp_D_lon`` (unit ``m``), to override the rad units of the catalogue.
    """
    r_m, r_n = earth.radii(lat0)
    north = StateUnit("m", float(r_m + h0))
    east = StateUnit("m", float((r_n + h0) * np.cos(lat0)))
    return {"dp_lat": north, "dp_lon": east, "dp_D_lat": north, "dp_D_lon": east}


class Layout:
    """An ordered composition of blocks; maps block names to slices of the state vector.

    Examples
    --------
    >>> lay = Layout(["phi", "dv", "dp", "eps", "nabla"])
    >>> lay["eps"]
    slice(9, 12, None)
    >>> lay.n
    15
    >>> (lay + ["mount", "dk"]).names[-1]
    'dk'
    """

    def __init__(self, blocks):
        self.blocks = tuple(b if isinstance(b, Block) else block(b) for b in blocks)
        seen = set()
        self._slices = {}
        start = 0
        for b in self.blocks:
            if b.name in seen:
                raise ValueError(f"state block {b.name!r} appears twice in the layout")
            seen.add(b.name)
            self._slices[b.name] = slice(start, start + b.size)
            start += b.size
        self.n = start
        self.names = tuple(n for b in self.blocks for n in b.names)
        self.units = tuple(u for b in self.blocks for u in b.units)
        self._index = {n: i for i, n in enumerate(self.names)}

    def __add__(self, more) -> "Layout":
        """A new layout with the blocks ``more`` appended."""
        return Layout(list(self.blocks) + list(more))

    def __contains__(self, name) -> bool:
        return name in self._slices

    def __getitem__(self, name) -> slice:
        """Slice of block ``name`` in the state vector."""
        try:
            return self._slices[name]
        except KeyError:
            raise KeyError(f"state block {name!r} is not in this layout "
                           f"({', '.join(self._slices)})") from None

    def index(self, element: str) -> int:
        """Position of one element (``"phi_U"``, ``"dk"``) in the state vector."""
        try:
            return self._index[element]
        except KeyError:
            raise KeyError(f"state element {element!r} is not in this layout") from None

    def offsets(self) -> np.ndarray:
        """(10,) int64: the first state of each of :data:`KERNEL_BLOCKS` (-1: not in this
        layout), indexed by the named constants :data:`PHI`, :data:`DV`, ... :data:`LEVER`."""
        return np.array([self._slices[b].start if b in self._slices else -1
                         for b in KERNEL_BLOCKS], dtype=np.int64)

    def zeros(self) -> np.ndarray:
        return np.zeros(self.n)

    def diag(self, values: dict) -> np.ndarray:
        """Diagonal matrix from ``{block: scalar or (size,) values}``; other blocks get 0."""
        d = np.zeros(self.n)
        for name, v in values.items():
            d[self[name]] = v
        return np.diag(d)

    def as_dict(self, x: np.ndarray) -> dict:
        """``{element name: x[..., i]}`` for a state vector or an (N, n) history."""
        x = np.asarray(x)
        return {n: x[..., i] for i, n in enumerate(self.names)}

    def unit_map(self, overrides: dict | None = None) -> dict:
        """``{element name: StateUnit}``, with ``overrides`` (e.g. :func:`position_units`)."""
        units = dict(zip(self.names, self.units))
        for k, u in (overrides or {}).items():
            if k in units:
                units[k] = u
        return units

    def __repr__(self):
        return "Layout(" + ", ".join(f"{b.name}:{b.size}" for b in self.blocks) + f"; n={self.n})"
