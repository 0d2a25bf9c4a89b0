"""What ``inmotion methods NAME`` prints and ``docs/methods.md`` holds: a method's settings
(name with unit, default, allowed range, meaning), the sensors it needs and its paper.

Everything comes from :mod:`inmotion.registry` and the method's pydantic configuration class
(every field carries a ``description``); the sensors and papers are listed here, once.
"""
from __future__ import annotations

import difflib
import re
import typing
from dataclasses import dataclass
from typing import Any, Iterable, Optional

from .. import registry

__all__ = ["PAPERS", "SENSORS", "ESTIMATES", "config_template", "Setting", "settings",
           "unit_of", "paper_of", "method_detail", "method_text", "methods_markdown",
           "did_you_mean"]

#: the five papers: number -> citation
PAPERS = {
    "000": "Yang, Xi, Yang, Xue: An Alignment Method for SINS Assisted by Doppler Radar on a "
           "Vehicle-Borne Moving Base, Sensors 2019",
    "001": "Xiang et al.: In-motion initial alignment for a LDV-aided SINS based on an adaptive "
           "unscented quaternion H-infinite filter, Meas. Sci. Technol. 2022",
    "002": "Yang et al.: Accurate integrated position and orientation method for vehicles based "
           "on SINS/Doppler radar, Meas. Control 2018",
    "003": "Chang et al.: In-Motion Initial Alignment Method Based on Multi-Source Information "
           "Fusion for Special Vehicles, Entropy 2025",
    "004": "Qiao et al.: Improved Multistage In-Motion Attitude Determination Alignment Method "
           "for SINS, Sensors 2019",
}

_VEL = "one forward-velocity sensor (radar, ldv or odometer)"
#: method -> the bundle tables it needs (beyond ``imu``) and those it uses when present
SENSORS = {
    "sins": ("imu", "baro (optional: height damping)"),
    "dr": ("imu", _VEL),
    "sins-dr": ("imu", _VEL, "baro (optional, use_baro)"),
    "dr-kf": ("imu", _VEL, "baro (optional, use_baro)"),
    "od-velocity-kf": ("imu", _VEL, "baro (optional, use_baro)"),
    "imada-vb": ("imu", _VEL),
    "imada-vn": ("imu", _VEL),
    "imada-dual": ("imu", _VEL),
    "mimada": ("imu", _VEL),
    "mimada-dual": ("imu", _VEL),
    "usque": ("imu", "one forward-velocity sensor (sensor: auto takes ldv, else radar, else "
                    "odometer)"),
    "ausque": ("imu", "one forward-velocity sensor (sensor: auto takes ldv, else radar, else "
                    "odometer)"),
    "usque-hinf": ("imu", "one forward-velocity sensor (sensor: auto takes ldv, else radar, else "
                    "odometer)"),
    "ausquhe": ("imu", "one forward-velocity sensor (sensor: auto takes ldv, else radar, else "
                    "odometer)"),
    "oba": ("imu", _VEL),
    "coarse-inertial": ("imu", "a velocity sensor in motion (none parked)"),
    "parked-kf": ("imu (vehicle parked)",),
    "od-kf": ("imu", "odometer", "baro (optional, use_baro)"),
    "ldv-kf": ("imu", "ldv", "baro (optional, use_baro)"),
    "nhc-kf": ("imu", "baro (optional, use_baro)"),
    "fkf": ("imu", "odometer", "ldv", "baro (optional, use_baro)"),
    "fine-mux": ("imu", "odometer and/or ldv (fine_method: auto picks fkf, od-kf or ldv-kf)"),
    "adaptive": ("imu", "odometer and/or ldv (fine_method: auto picks fkf, od-kf or ldv-kf)",
                 "baro (optional)"),
}

_KF = ("misalignment phi, velocity dv and position dp errors, gyro drift eps, accelerometer "
       "bias nabla")
#: method -> what it estimates (its state vector or its output), in words
ESTIMATES = {
    "sins": "position, velocity and attitude by strapdown mechanization; no error states",
    "dr": "attitude from the gyros, position from the velocity sensor's distance; no error "
          "states",
    "sins-dr": "22 states: " + _KF + ", the DR's misalignment phi_D and position dp_D, the "
               "sensor scale factor dk (paper 002)",
    "dr-kf": "25 states: " + _KF + ", phi_D, dp_D, the mounting angles mount_x/y/z, the scale "
             "factor dk (paper 000 eq. 21)",
    "od-velocity-kf": "19 states: " + _KF + ", the mounting angles, the scale factor dk",
    "imada-vb": "the attitude at the window's start C_b^n(0) by the q-method, then C_b^n(t) "
                "along the gyros; quality: the eigenvalue gap",
    "imada-vn": "as imada-vb, with the navigation-velocity model",
    "imada-dual": "as imada-vb, with the dual velocity model",
    "mimada": "as imada-vb, in levels (multistage)",
    "mimada-dual": "as imada-vb, in levels with the dual model at the later ones",
    "usque": "attitude (quaternion, GRP error) by an unscented filter; optionally the scale "
             "factor, accelerometer bias, gyro drift and the initial speed error",
    "ausque": "as usque, with adaptive measurement noise",
    "usque-hinf": "as usque, with an H-infinity covariance update",
    "ausquhe": "as usque, with adaptive noise and adaptive H-infinity gamma",
    "oba": "attitude by optimization-based alignment (q-method on observation vectors)",
    "coarse-inertial": "attitude from gravity in the inertial frame (parked or moving)",
    "parked-kf": "12 states: misalignment, velocity error, gyro drift, accelerometer bias",
    "od-kf": "21 states: " + _KF + ", odometer scale factor dk, mounting mount_x/mount_z, "
             "lever arm (paper 003 eq. 14-26)",
    "ldv-kf": "21 states as od-kf, for the LDV",
    "nhc-kf": "15 states: " + _KF + " (paper 003 eq. 27-31)",
    "fkf": "the 21 states of od-kf and ldv-kf in two sub-filters, fused (federated)",
    "fine-mux": "coarse attitude on the fault-tolerant speed, then the fine method's states",
    "adaptive": "parked / moving detection, then the states of the stage it chooses",
}

# unit suffixes of field names, longest first
_UNITS = (("_deg_h_sqrt_h", "deg/h/sqrt(h)"), ("_ug_sqrt_hz", "ug/sqrt(Hz)"),
          ("_ug_sqrt_h", "ug/sqrt(h)"), ("_deg_sqrt_h", "deg/sqrt(h)"),
          ("_deg_sqrt_s", "deg*sqrt(s)"), ("_deg_h", "deg/h"), ("_arcmin", "arcmin"),
          ("_deg", "deg"), ("_m_s", "m/s"), ("_ppm", "ppm"), ("_hz", "Hz"), ("_ug", "ug"),
          ("_m", "m"), ("_s", "s"))


def unit_of(name: str) -> str:
    """The unit a field name carries (``gyro_drift_deg_h`` -> ``deg/h``), or ``""``."""
    for suffix, unit in _UNITS:
        if name.endswith(suffix):
            return unit
    return ""


def paper_of(summary: str) -> Optional[str]:
    """The paper number a method's summary cites (``"paper 004 eq. 9"`` -> ``"004"``)."""
    m = re.search(r"paper (\d{3})", summary)
    return m.group(1) if m else None


@dataclass(frozen=True)
class Setting:
    """One configuration field, in words."""

    name: str
    unit: str
    type: str
    default: Any
    allowed: str
    meaning: str


def _type_text(ann) -> tuple[str, str, bool]:
    """``(type, allowed choices, None allowed)`` of an annotation."""
    origin = typing.get_origin(ann)
    args = typing.get_args(ann)
    if origin is typing.Union:
        rest = [a for a in args if a is not type(None)]
        parts = [_type_text(a) for a in rest]
        t = " or ".join(p[0] for p in parts)
        allowed = " | ".join(p[1] or p[0] for p in parts) if len(parts) > 1 else parts[0][1]
        return t, allowed, len(rest) < len(args)
    if origin is typing.Literal:
        return "choice", " | ".join(str(a) for a in args), False
    if origin in (tuple, list):
        inner = args[0].__name__ if args and hasattr(args[0], "__name__") else "value"
        n = f"{len(args)} x " if origin is tuple and args and args[-1] is not Ellipsis else ""
        return (f"{n}{inner}" if n else f"list of {inner}"), "", False
    if ann is bool:
        return "bool", "true | false", False
    if ann is dict:
        return "mapping", "", False
    return getattr(ann, "__name__", str(ann)), "", False


def _bounds(field) -> str:
    parts = []
    for m in field.metadata:
        for attr, sym in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
            v = getattr(m, attr, None)
            if v is not None:
                parts.append(f"{sym} {v:g}" if isinstance(v, (int, float)) else f"{sym} {v}")
        for attr, sym in (("min_length", "length >="), ("max_length", "length <=")):
            v = getattr(m, attr, None)
            if v is not None:
                parts.append(f"{sym} {v}")
    text = ", ".join(parts)
    m = re.fullmatch(r"length >= (\d+), length <= (\d+)", text)
    return f"length {m.group(1)}" if m and m.group(1) == m.group(2) else text


def _default_text(v) -> Any:
    if isinstance(v, tuple):
        return list(v)
    return v


def settings(config_class) -> list[Setting]:
    """Every field of a pydantic configuration class as a :class:`Setting`."""
    out = []
    for name, f in config_class.model_fields.items():
        t, choices, nullable = _type_text(f.annotation)
        allowed = ", ".join(x for x in (choices, _bounds(f)) if x) or t
        if nullable:
            allowed = f"{allowed} or null"
        default = f.get_default(call_default_factory=True)
        meaning = re.sub(r"\bNone\b", "null", (f.description or "").strip())
        out.append(Setting(name, unit_of(name), t, _default_text(default), allowed, meaning))
    return out


def _value_text(v) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, dict) and not v:
        return "{}"
    return str(v)


def method_detail(name: str) -> dict:
    """Everything about one method, JSON-ready (``inmotion --json methods NAME``)."""
    spec = registry.get(name)
    _, config = spec.load()
    paper = paper_of(spec.summary)
    return {"name": spec.name, "kind": spec.kind, "summary": spec.summary,
            "needs_attitude": spec.needs_attitude,
            "sensors": list(SENSORS.get(spec.name, ("imu",))),
            "estimates": ESTIMATES.get(spec.name, ""),
            "paper": {"number": paper, "citation": PAPERS.get(paper)} if paper else None,
            "config_class": f"{config.__module__}.{config.__name__}",
            "settings": [s.__dict__ for s in settings(config)]}


def method_text(name: str) -> str:
    """The text ``inmotion methods NAME`` prints."""
    d = method_detail(name)
    lines = [f"{d['name']} ({d['kind']}): {d['summary']}",
             f"  needs:    {', '.join(d['sensors'])}",
             f"  estimates: {d['estimates']}",
             "  initial attitude: " + ("needed (--init truth | meta | RESULT)"
                                       if d["needs_attitude"] else "not needed (found by the "
                                                                   "method)")]
    if d["paper"]:
        lines.append(f"  paper {d['paper']['number']}: {d['paper']['citation']}")
    lines.append(f"  settings ({d['config_class']}; set with --set NAME=VALUE or --config FILE):")
    rows = [(s["name"] + (f" [{s['unit']}]" if s["unit"] else ""), _value_text(s["default"]),
             s["allowed"], s["meaning"]) for s in d["settings"]]
    w0 = max(len("name [unit]"), *(len(r[0]) for r in rows))
    w1 = min(max(len("default"), *(len(r[1]) for r in rows)), 24)
    w2 = min(max(len("allowed"), *(len(r[2]) for r in rows)), 28)
    lines.append(f"    {'name [unit]':{w0}s}  {'default':{w1}s}  {'allowed':{w2}s}  meaning")
    for r in rows:
        lines.append(f"    {r[0]:{w0}s}  {r[1]:{w1}s}  {r[2]:{w2}s}  {r[3]}")
    return "\n".join(lines)


def config_template(name: str) -> str:
    """A YAML configuration of the method with every setting at its default and its unit,
    range and meaning as a comment: edit it and pass it to ``--config``."""
    import json
    d = method_detail(name)
    lines = [f"# {d['name']} ({d['kind']}): {d['summary']}",
             f"# inmotion {d['kind']} BUNDLE --method {d['name']} --config THIS_FILE -o RESULT",
             "# every setting below is at its default; units are in the names"]
    for s in d["settings"]:
        text = json.dumps(s["default"])            # JSON is YAML: null, true, "quoted"
        lines.append(f"{s['name']}: {text}    # {s['meaning']}; allowed: {s['allowed']}")
    return "\n".join(lines) + "\n"


def methods_markdown() -> str:
    """``docs/methods.md``: every method, what it needs, its paper and its settings."""
    out = ["# Methods", "",
           "Generated from the registry and the configuration classes by",
           "`inmotion.cli.method_docs.methods_markdown()` (a test keeps this page current);",
           "`inmotion methods NAME` prints the same on the command line. Settings carry their",
           "unit in the name; set them with `--set NAME=VALUE` or in a YAML file given to",
           "`--config`.", "",
           "| method | kind | needs | initial attitude | paper |",
           "| --- | --- | --- | --- | --- |"]
    for spec in registry.methods():
        p = paper_of(spec.summary)
        out.append(f"| [`{spec.name}`](#{spec.name}) | {spec.kind} | "
                   f"{', '.join(SENSORS.get(spec.name, ('imu',)))} | "
                   f"{'needed' if spec.needs_attitude else 'found'} | {p or '-'} |")
    out += ["", "## Papers", ""]
    out += [f"- **{k}**: {v}" for k, v in PAPERS.items()]
    for spec in registry.methods():
        d = method_detail(spec.name)
        out += ["", f"## {spec.name}", "", f"{spec.kind}: {spec.summary}.", "",
                f"- needs: {', '.join(d['sensors'])}",
                f"- estimates: {d['estimates']}",
                "- initial attitude: " + ("needed" if d["needs_attitude"]
                                          else "not needed (the method finds it)")]
        if d["paper"]:
            out.append(f"- paper {d['paper']['number']}: {d['paper']['citation']}")
        out.append(f"- configuration class: `{d['config_class']}`")
        out += ["", "| setting | unit | default | allowed | meaning |",
                "| --- | --- | --- | --- | --- |"]
        for s in d["settings"]:
            out.append(f"| `{s['name']}` | {s['unit'] or '-'} | "
                       f"{_md(_value_text(s['default']))} | {_md(s['allowed'])} | "
                       f"{_md(s['meaning'])} |")
    return "\n".join(out) + "\n"


def _md(text: str) -> str:
    """``text`` safe in a markdown table cell: no column breaks, no link brackets."""
    return (text.replace("|", "&#124;").replace("[", "\\[").replace("]", "\\]")
            .replace("*", "\\*").replace("_", "\\_"))


def did_you_mean(name: str, candidates: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the closest candidates, or ``""``."""
    close = difflib.get_close_matches(name, list(candidates), n=3, cutoff=0.6)
    if not close:
        return ""
    return "; did you mean " + " or ".join(repr(c) for c in close) + "?"
