"""The sampled series of a run: their names and their units (one place for both).

:data:`SERIES` are the series a :class:`mett.Trajectory` derives from its states (besides ``t``);
:data:`SERIES_UNITS` gives the SI unit and a long name of every series a run may carry, used by the
exports (CSV headers, xarray/NetCDF attributes).
"""

from __future__ import annotations

__all__ = ["SERIES", "SERIES_UNITS"]

SERIES = (
    "theta",
    "thetadot",
    "phidot",
    "psidot",
    "omega3",
    "nu_x",
    "nu_y",
    "gn",
    "x",
    "y",
    "phi",
    "E",
    "E_mod",
    "D",
    "lam",
)
"""Names of the sampled series of a :class:`Trajectory` derived from its states (besides ``t``)."""

SERIES_UNITS: dict[str, tuple[str, str]] = {
    "t": ("s", "time"),
    "theta": ("rad", "nutation angle theta between the symmetry axis and the vertical"),
    "thetadot": ("rad/s", "nutation rate dtheta/dt"),
    "phidot": ("rad/s", "precession rate dphi/dt"),
    "psidot": ("rad/s", "spin rate dpsi/dt = omega3 - phidot cos(theta)"),
    "psi": ("rad", "spin angle psi (Euler angle about the symmetry axis)"),
    "omega3": ("rad/s", "angular velocity about the symmetry axis omega3"),
    "nu_x": ("m/s", "gliding velocity of the contact point along x"),
    "nu_y": ("m/s", "gliding velocity of the contact point along y"),
    "gn": ("N", "normal force g_n"),
    "x": ("m", "horizontal position x of the centre of mass"),
    "y": ("m", "horizontal position y of the centre of mass"),
    "phi": ("rad", "precession angle phi of the axis, in (-pi, pi]"),
    "E": ("J", "energy E"),
    "E_mod": ("J", "modified energy E~ (the METT's energy while gliding)"),
    "D": ("kg m^2/s", "Routh integral D"),
    "lam": ("kg m^3/s", "Jellett integral lambda"),
    "F_x": ("N", "friction force along x"),
    "F_y": ("N", "friction force along y"),
    "M_n": ("N m", "friction torque about the vertical"),
    "margin": ("1", "stick margin of the contact (dry friction)"),
    "phase": ("", "contact phase of the sample"),
    "contact": ("", "which sphere touches the plane (ball, stem, or none in flight)"),
    "gap": ("m", "height of the lowest point of the sphere above the plane (0 in contact)"),
    "gap_rate": ("m/s", "rate of the gap of the lowest point of the sphere"),
}
"""Unit and long name of every series a :class:`mett.Trajectory` may carry (SI units)."""
