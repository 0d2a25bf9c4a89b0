"""The report's figures (matplotlib, Agg back end): error curves with 3-sigma envelopes, Monte
Carlo envelopes, distributions of final errors per point, and the plan view of a drive.

Every function returns a ``matplotlib.figure.Figure`` made without pyplot's global state, so
figures can be built in any thread and never open a window; :func:`png_bytes` renders one.
Units are those of the error columns (``*_arcmin``, ``*_m_s``, ``*_m``), named on the axes.
"""
from __future__ import annotations

import io
import textwrap

import numpy as np
from matplotlib.figure import Figure

__all__ = ["ERROR_GROUPS", "ERROR_WORDS", "png_bytes", "error_curves", "abs_error_curves",
           "ensemble_curves", "final_distributions", "state_curves", "state_words", "plan_view",
           "position_error_plan"]

#: rows of the error-curve figures: (title, error columns)
ERROR_GROUPS = (
    ("misalignment", ("phi_E_arcmin", "phi_N_arcmin", "phi_U_arcmin")),
    ("velocity", ("vE_m_s", "vN_m_s", "vU_m_s")),
    ("position", ("north_m", "east_m", "vertical_m")),
)
MAX_LINE_POINTS = 4000

#: error column -> (what it is in words, unit)
ERROR_WORDS = {
    "pitch_arcmin": ("pitch error", "arcmin"), "roll_arcmin": ("roll error", "arcmin"),
    "yaw_arcmin": ("heading (yaw) error", "arcmin"),
    "phi_E_arcmin": ("misalignment about East (level)", "arcmin"),
    "phi_N_arcmin": ("misalignment about North (level)", "arcmin"),
    "phi_U_arcmin": ("misalignment about Up (heading)", "arcmin"),
    "vE_m_s": ("East velocity error", "m/s"), "vN_m_s": ("North velocity error", "m/s"),
    "vU_m_s": ("Up velocity error", "m/s"),
    "north_m": ("North position error", "m"), "east_m": ("East position error", "m"),
    "horizontal_m": ("horizontal position error", "m"),
    "vertical_m": ("vertical position error", "m"),
}

#: state name prefix -> one line of meaning (``states.csv`` columns are ``<name>_<unit>``)
STATE_MEANINGS = (
    ("sigma_", "1-sigma of "),
    ("eigval_gap_rel", "q-method eigenvalue gap, relative: how well the attitude is "
                       "determined (larger is better)"),
    ("phi_D_", "dead reckoner's misalignment"), ("dp_D_", "dead reckoner's position error"),
    ("phi_", "misalignment estimate"), ("dv_", "velocity error estimate"),
    ("dp_", "position error estimate"), ("eps_", "gyro drift estimate (b frame)"),
    ("nabla_", "accelerometer bias estimate (b frame)"),
    ("mount_x", "mounting angle about the right axis (pitch mounting)"),
    ("mount_y", "mounting angle about the forward axis (roll mounting)"),
    ("mount_z", "mounting angle about the up axis (yaw mounting)"),
    ("dk", "velocity sensor scale-factor error"), ("lever_", "lever arm error"),
    ("dv0", "error of the speed sample taken as v^b(0)"),
    ("gamma", "H-infinity gamma"), ("R_", "adaptive measurement noise"),
)
_UNIT_WORDS = (("_deg_h", "deg/h"), ("_arcmin", "arcmin"), ("_ratio", "ratio"), ("_m_s", "m/s"),
               ("_ppm", "ppm"), ("_ug", "ug"), ("_rad", "rad"), ("_deg", "deg"), ("_m", "m"),
               ("_si", "SI"))


def png_bytes(fig: Figure, dpi: int = 90) -> bytes:
    """The figure as PNG bytes."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def _thin(n: int) -> slice:
    return slice(None, None, max(1, -(-n // MAX_LINE_POINTS)))


def _unit_label(column: str) -> str:
    """``"phi_E_arcmin" -> "phi_E [arcmin]"``."""
    for suffix, text in (("_arcmin", "arcmin"), ("_m_s", "m/s"), ("_m", "m")):
        if column.endswith(suffix):
            return f"{column[: -len(suffix)]} [{text}]"
    return column


def state_words(column: str) -> tuple[str, str, str]:
    """``(name, unit, meaning)`` of a ``states.csv`` column:
    ``"eps_x_deg_h" -> ("eps_x", "deg/h", "gyro drift estimate (b frame)")``."""
    name, unit = column, ""
    for suffix, text in _UNIT_WORDS:
        if column.endswith(suffix):
            name, unit = column[: -len(suffix)], text
            break
    meaning, rest = "", name
    while True:
        for prefix, words in STATE_MEANINGS:
            if rest.startswith(prefix):
                meaning += words
                rest = rest[len(prefix):] if prefix == "sigma_" else ""
                break
        else:
            break
        if not rest:
            break
    return name, unit, meaning or "estimated state"


def _grid(columns_present):
    groups = [(title, [c for c in cols if c in columns_present]) for title, cols in ERROR_GROUPS]
    return [(title, cols) for title, cols in groups if cols]


def _column_grid(columns_present, draw, title: str) -> Figure:
    """The layout :func:`error_curves` and :func:`ensemble_curves` share: one row of three
    panels per group of :func:`_grid` (unused panels hidden), ``draw(ax, column)`` fills a
    panel; unit labels, grid, group titles, time axis, one legend and the title around it."""
    groups = _grid(columns_present)
    fig = Figure(figsize=(12, 2.6 * max(1, len(groups))), layout="constrained")
    axes = fig.subplots(max(1, len(groups)), 3, squeeze=False, sharex=True)
    for r, (gtitle, cols) in enumerate(groups):
        for c in range(3):
            ax = axes[r, c]
            if c >= len(cols):
                ax.set_visible(False)
                continue
            draw(ax, cols[c])
            ax.set_ylabel(_unit_label(cols[c]))
            ax.grid(alpha=0.3)
        axes[r, 0].set_title(gtitle, loc="left", fontsize=10)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    axes[0, 0].legend(loc="best", fontsize=8)
    if title:
        fig.suptitle(title)
    return fig


def error_curves(t, errors: dict, sigma: dict, title: str = "") -> Figure:
    """One run: each error column against time, with the method's +-3 sigma shaded.

    Parameters
    ----------
    t : (N,) s
    errors : column -> (N,) error, estimate minus truth (columns of ``error_series``)
    sigma : column -> (N,) the method's 1-sigma for that column, same unit (may be empty)
    """
    sl = _thin(len(t))

    def draw(ax, col):
        ax.plot(t[sl], errors[col][sl], lw=0.9, color="C0", label="error")
        if col in sigma and np.isfinite(sigma[col]).any():
            s3 = 3.0 * np.asarray(sigma[col])[sl]
            ax.fill_between(t[sl], -s3, s3, color="C1", alpha=0.25, lw=0, label="±3σ (filter)")

    return _column_grid(errors, draw, title)


def abs_error_curves(t, errors: dict, sigma: dict, title: str = "") -> Figure:
    """One run: ``|error|`` of each column on a log scale with the method's 3 sigma, so the
    converged error stays readable after a start-up transient thousands of times larger.

    Parameters as :func:`error_curves`.
    """
    sl = _thin(len(t))

    def draw(ax, col):
        e = np.abs(np.asarray(errors[col], dtype=float)[sl])
        floor = max(np.nanmax(e) * 1e-9, 1e-12) if np.isfinite(e).any() else 1e-12
        ax.semilogy(t[sl], np.maximum(e, floor), lw=0.9, color="C0", label="|error|")
        if col in sigma and np.isfinite(sigma[col]).any():
            ax.semilogy(t[sl], 3.0 * np.asarray(sigma[col])[sl], "--", lw=1.0, color="C1",
                        label="3σ (filter)")

    fig = _column_grid(errors, draw, title)
    for ax in fig.axes:
        if ax.get_visible() and ax.get_ylabel():
            ax.set_ylabel("|" + ax.get_ylabel().replace(" [", "| [", 1))
    return fig


def ensemble_curves(t, runs: dict, sigma: dict, title: str = "") -> Figure:
    """Monte Carlo runs of one point: every run thin, the ensemble mean +- 3 std shaded, and the
    filter's RMS 1-sigma times 3 dashed (the two envelopes agree for a consistent filter).

    Parameters
    ----------
    t : (N,) s, the common time base
    runs : column -> (R, N) errors of the R runs
    sigma : column -> (R, N) the filter's 1-sigma of the runs (may be empty)
    """
    sl = _thin(len(t))

    def draw(ax, col):
        x = np.asarray(runs[col])[:, sl]
        ax.plot(t[sl], x.T, lw=0.4, color="0.6", alpha=0.6)
        mean, std = x.mean(axis=0), x.std(axis=0)
        ax.fill_between(t[sl], mean - 3 * std, mean + 3 * std, color="C0", alpha=0.2, lw=0,
                        label="ensemble mean ±3 std")
        ax.plot(t[sl], mean, color="C0", lw=1.0)
        if col in sigma:
            s = np.sqrt(np.nanmean(np.square(np.asarray(sigma[col])[:, sl]), axis=0))
            ax.plot(t[sl], 3 * s, "--", color="C3", lw=1.0, label="±3σ filter (RMS)")
            ax.plot(t[sl], -3 * s, "--", color="C3", lw=1.0)

    return _column_grid(runs, draw, title)


def final_distributions(values: dict, columns, title: str = "") -> Figure:
    """Distribution of final errors: for each column a box plot per point, runs dotted on it.

    Parameters
    ----------
    values : point label -> {column: (R,) final errors of its ok runs}
    columns : the columns to show, one panel each
    """
    columns = list(columns)
    ncol = min(3, max(1, len(columns)))
    nrow = -(-len(columns) // ncol) if columns else 1
    labels = list(values)
    fig = Figure(figsize=(4.2 * ncol, 0.5 + max(2.2, 0.38 * len(labels) + 1.0) * nrow),
                 layout="constrained")
    axes = np.atleast_1d(fig.subplots(nrow, ncol, squeeze=False)).ravel()
    rng = np.random.default_rng(0)   # jitter of the dots only, not data
    for ax, col in zip(axes, columns):
        data = [np.asarray(values[lab].get(col, []), dtype=float) for lab in labels]
        data = [d[np.isfinite(d)] for d in data]
        pos = np.arange(1, len(labels) + 1)
        ax.boxplot([d if len(d) else [np.nan] for d in data], positions=pos, orientation="horizontal",
                   widths=0.6, showfliers=False)
        for p, d in zip(pos, data):
            ax.plot(d, p + rng.uniform(-0.18, 0.18, len(d)), ".", ms=3, alpha=0.6, color="C0")
        ax.set_yticks(pos, labels if ax is axes[0] or ncol == 1 else [""] * len(labels),
                      fontsize=8)
        ax.axvline(0.0, color="0.5", lw=0.6)
        ax.set_xlabel(_unit_label(col.rsplit(".", 1)[-1]))
        ax.grid(alpha=0.3, axis="x")
    for ax in axes[len(columns):]:
        ax.set_visible(False)
    for r in range(nrow):
        axes[r * ncol].set_yticks(np.arange(1, len(labels) + 1), labels, fontsize=8)
    if title:
        fig.suptitle(title)
    return fig


def state_curves(t, states: dict, sigma: dict, title: str = "") -> Figure:
    """Estimated states against time, each with its +-3 sigma where the method gives one.

    Parameters
    ----------
    t : (N,) s
    states : column (name with unit, as in ``states.csv``) -> (N,) value
    sigma : column -> (N,) 1-sigma in the same unit (may miss columns)
    """
    cols = list(states)
    ncol = min(4, max(1, len(cols)))
    nrow = max(1, -(-len(cols) // ncol))
    fig = Figure(figsize=(3.4 * ncol, 2.5 * nrow), layout="constrained")
    axes = np.atleast_1d(fig.subplots(nrow, ncol, squeeze=False, sharex=True)).ravel()
    sl = _thin(len(t))
    for ax, col in zip(axes, cols):
        x = np.asarray(states[col])[sl]
        ax.plot(t[sl], x, lw=0.9, color="C0")
        if col in sigma:
            s3 = 3.0 * np.asarray(sigma[col])[sl]
            ax.fill_between(t[sl], x - s3, x + s3, color="C1", alpha=0.25, lw=0)
        name, unit, meaning = state_words(col)
        ax.set_title(f"{name} [{unit or '-'}]\n" + "\n".join(textwrap.wrap(meaning, 44)),
                     fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes[len(cols):]:
        ax.set_visible(False)
    for ax in axes[-ncol:]:
        ax.set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    return fig


def plan_view(tracks, title: str = "") -> Figure:
    """Map-like plan view: north against east [m, or km past 5 km], equal scale.

    Parameters
    ----------
    tracks : list of (label, east_m (N,), north_m (N,))
    """
    fig = Figure(figsize=(7, 6.5), layout="constrained")
    ax = fig.subplots()
    span = max((np.ptp(np.concatenate([e, n])) for _, e, n in tracks if len(e)), default=0.0)
    scale, unit = (1e-3, "km") if span > 5000 else (1.0, "m")
    for i, (label, east, north) in enumerate(tracks):
        sl = _thin(len(east))
        ax.plot(np.asarray(east)[sl] * scale, np.asarray(north)[sl] * scale, lw=1.2 if i == 0 else 0.9,
                label=label, color=f"C{i}")
    if tracks and len(tracks[0][1]):
        _, e, n = tracks[0]
        ax.plot(e[0] * scale, n[0] * scale, "o", color="green", label="start")
        ax.plot(e[-1] * scale, n[-1] * scale, "s", color="black", label="end")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"east [{unit}]")
    ax.set_ylabel(f"north [{unit}]")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "plan view")
    return fig


def position_error_plan(t, east_err, north_err, title: str = "") -> Figure:
    """Plan view of the horizontal position error: north error against east error [m], equal
    scale, coloured by time, with the start, the end and the circle of the final error."""
    t = np.asarray(t, dtype=float)
    e, n = np.asarray(east_err, dtype=float), np.asarray(north_err, dtype=float)
    fig = Figure(figsize=(6.5, 5.8), layout="constrained")
    ax = fig.subplots()
    sl = _thin(len(t))
    sc = ax.scatter(e[sl], n[sl], c=t[sl], s=4, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="t [s]")
    ax.plot(e[0], n[0], "o", color="green", label="start")
    ax.plot(e[-1], n[-1], "s", color="black", label=f"end: {np.hypot(e[-1], n[-1]):.3g} m")
    r = float(np.hypot(e[-1], n[-1]))
    if r > 0:
        a = np.linspace(0, 2 * np.pi, 200)
        ax.plot(r * np.cos(a), r * np.sin(a), ":", color="0.4", lw=0.8)
    ax.axhline(0, color="0.6", lw=0.6)
    ax.axvline(0, color="0.6", lw=0.6)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east error [m]")
    ax.set_ylabel("north error [m]")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "horizontal position error (estimate minus truth)")
    return fig
