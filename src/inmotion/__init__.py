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
"""

__version__ = "0.1.0"
