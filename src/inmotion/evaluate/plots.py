"""The report's figures (matplotlib, Agg back end): error curves with 3-sigma envelopes, Monte
Carlo envelopes, distributions of final errors per point, and the plan view of a drive.

Every function returns a ``matplotlib.figure.Figure`` made without pyplot's global state, so
figures can be built in any thread and never open a window; :func:`png_bytes` renders one.
Units are those of the error columns (``*_arcmin``, ``*_m_s``, ``*_m``), named on the axes.
"""
from __future__ import annotations

import io

import numpy as np
from matplotlib.figure import Figure

__all__ = ["ERROR_GROUPS", "png_bytes", "error_curves", "ensemble_curves",
           "final_distributions", "state_curves", "plan_view"]

#: rows of the error-curve figures: (title, error columns)
ERROR_GROUPS = (
    ("misalignment", ("phi_E_arcmin", "phi_N_arcmin", "phi_U_arcmin")),
    ("velocity", ("vE_m_s", "vN_m_s", "vU_m_s")),
    ("position", ("north_m", "east_m", "vertical_m")),
)
MAX_LINE_POINTS = 4000


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
    fig = Figure(figsize=(3.2 * ncol, 2.3 * nrow), layout="constrained")
    axes = np.atleast_1d(fig.subplots(nrow, ncol, squeeze=False, sharex=True)).ravel()
    sl = _thin(len(t))
    for ax, col in zip(axes, cols):
        x = np.asarray(states[col])[sl]
        ax.plot(t[sl], x, lw=0.9, color="C0")
        if col in sigma:
            s3 = 3.0 * np.asarray(sigma[col])[sl]
            ax.fill_between(t[sl], x - s3, x + s3, color="C1", alpha=0.25, lw=0)
        ax.set_title(col, fontsize=9)
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
