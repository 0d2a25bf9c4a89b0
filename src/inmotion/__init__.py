"""inmotion: in-motion alignment and navigation of land vehicles.

A strapdown inertial navigation system (SINS) aided by the vehicle's own velocity sensors
(Doppler radar, laser Doppler velocimeter (LDV), odometer), with no satellite signal.

Conventions (the charter every module keeps; see ``docs/conventions.md``)
--------------------------------------------------------------------------
Frames
    ``n``  navigation frame, East-North-Up (ENU), at the vehicle's position.
    ``b``  body frame, Right-Forward-Up (x right, y forward, z up). The IMU frame equals b
           unless a mounting matrix is given.
    ``e``  Earth-centred Earth-fixed; ``i`` inertial.
    ``m``  a velocity sensor's own frame (radar, LDV, odometer); its forward axis is y.
Naming
    ``vec_a``  a vector resolved in frame a (``omega_ie_n`` is the Earth rate in n).
    ``mat_ab`` / ``C_ab`` the matrix that takes a vector from frame b to frame a, i.e.
               ``C_nb = C_b^n`` and ``vec_n = C_nb @ vec_b``.
Attitude
    ``C_b^n``; Euler angles ``[pitch, roll, yaw] = [theta, gamma, psi]`` with
    ``C_b^n = R_z(-psi) R_x(theta) R_y(gamma)``: ``pitch = asin(C32)``,
    ``roll = atan2(-C31, C33)``, ``yaw = atan2(C12, C22)``. Yaw is the heading, clockwise from
    North, reported in [0, 360) deg at the edges.
    Quaternions are scalar-first ``[q0, q1, q2, q3]`` (Hamilton), ``q_nb`` rotates b into n.
    Misalignment ``phi``: ``C_b^n(computed) = (I - [phi x]) C_b^n(true)``.
Units
    SI inside: rad, m, s, m/s, m/s^2; latitude and longitude in rad. Human units (deg,
    arc-min, deg/h, ug, deg/sqrt(h), ppm) only at the edges, always written with the unit.
Randomness
    Every random draw goes through a ``numpy.random.Generator`` passed in.
Error states
    Indexed by name through a layout object, never by bare numbers.

The Python API
--------------
``import inmotion`` is cheap (no numba, scipy or pandas); each name below is imported on first
use (module ``__getattr__``)::

    b = inmotion.simulate("demo", seed)                 # or inmotion.read_bundle(folder)
    sol = inmotion.run("sins-dr", b, {"filter_rate_hz": 10})
    inmotion.evaluate(sol, b)                            # the errors block vs truth

Bundles: ``read_bundle``, ``write_bundle``, ``Bundle``; results: ``read_result``,
``write_result``, ``Solution``, ``NavState``; simulation: ``simulate``, ``load_scenario``,
``scenarios``; methods: ``methods``, ``method_config``, ``run``, ``initial_state``;
evaluation: ``evaluate``, ``error_series``; the streaming filter: ``ErrorStateFilter``,
``Layout``, ``ErrorModel``, ``ProcessNoise`` and the ``measurements`` module; errors:
``BadInput``. Extending (a new measurement, a new method): ``docs/extending.md``.
"""

__version__ = "0.1.0"

#: public name -> "module" (the module itself) or "module:attribute", imported on first use
_LAZY = {
    "read_bundle": "inmotion.io.bundle:read_bundle",
    "write_bundle": "inmotion.io.bundle:write_bundle",
    "read_result": "inmotion.io.result:read_result",
    "write_result": "inmotion.io.result:write_result",
    "simulate": "inmotion.api:simulate",
    "load_scenario": "inmotion.api:load_scenario",
    "scenarios": "inmotion.api:scenarios",
    "methods": "inmotion.api:methods",
    "method_config": "inmotion.api:method_config",
    "run": "inmotion.api:run",
    "initial_state": "inmotion.api:initial_state",
    "evaluate": "inmotion.evaluate",        # the package, callable as api.evaluate
    "error_series": "inmotion.api:error_series",
    "ErrorStateFilter": "inmotion.estimation.engine:ErrorStateFilter",
    "Layout": "inmotion.estimation.layout:Layout",
    "ErrorModel": "inmotion.estimation.error_model:ErrorModel",
    "ProcessNoise": "inmotion.estimation.error_model:ProcessNoise",
    "measurements": "inmotion.estimation.measurements",
    "Bundle": "inmotion.core.bundle:Bundle",
    "NavState": "inmotion.core.solution:NavState",
    "Solution": "inmotion.core.solution:Solution",
    "BadInput": "inmotion.errors:BadInput",
}

__all__ = sorted(_LAZY) + ["__version__"]


def __getattr__(name):
    try:
        target = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'inmotion' has no attribute {name!r}") from None
    import importlib
    mod, _, attr = target.partition(":")
    value = importlib.import_module(mod)
    if attr:
        value = getattr(value, attr)
    globals()[name] = value            # later look-ups skip __getattr__
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
