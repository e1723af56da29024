"""The reduced state of the tippe top: (θ, θ̇, φ̇, ω3, ν_x, ν_y) (thesis eqs (10)–(15)).

θ is the angle between the vertical ẑ and the symmetry axis 3̂ (θ = 0: peg up, not inverted); φ̇ the
precession rate; ω3 = ψ̇ + φ̇ cos θ the spin about 3̂; (ν_x, ν_y) the gliding velocity of the contact
point in the horizontal frame x̂ = ŷ × ẑ, ŷ = ẑ × 3̂ / sin θ (docs/theory/model.md#conventions). The horizontal position and
the angles φ, ψ are cyclic and not part of the state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from . import _validate
from .top import TippeTop

__all__ = ["State"]

_FIELDS = ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y")


@dataclass(frozen=True)
class State:
    """Instantaneous state of the top. Fields may be arrays of one shape (a batch of states).

    Parameters
    ----------
    theta : float or array
        Inclination θ in [0, π] (rad).
    thetadot, phidot, omega3 : float or array, default 0
        θ̇, φ̇ and the spin ω3 = ψ̇ + φ̇ cos θ (rad/s).
    nu_x, nu_y : float or array, default 0
        Gliding velocity of the contact point (m/s). The default ν = 0 (contact point at rest) is
        the thesis start; :meth:`with_cm_at_rest` gives the other common start.
    """

    theta: float | np.ndarray
    thetadot: float | np.ndarray = 0.0
    phidot: float | np.ndarray = 0.0
    omega3: float | np.ndarray = 0.0
    nu_x: float | np.ndarray = 0.0
    nu_y: float | np.ndarray = 0.0

    if TYPE_CHECKING:  # what the dataclass's generated constructor takes, for type checkers

        def __init__(
            self,
            theta: ArrayLike,
            thetadot: ArrayLike = 0.0,
            phidot: ArrayLike = 0.0,
            omega3: ArrayLike = 0.0,
            nu_x: ArrayLike = 0.0,
            nu_y: ArrayLike = 0.0,
        ) -> None: ...

    def __post_init__(self) -> None:
        plain = [getattr(self, name) for name in _FIELDS]
        if all(type(v) is float and math.isfinite(v) for v in plain) and 0.0 <= plain[0] <= math.pi:
            return  # one state of valid Python floats: the common case, nothing to convert
        values = {name: getattr(self, name) for name in _FIELDS}
        values["theta"] = _validate.theta(values["theta"])
        for name in _FIELDS[1:]:
            values[name] = _validate.as_finite_array(name, values[name])
        if all(np.ndim(v) == 0 for v in values.values()):  # one state: the common case, fast
            for name, v in values.items():
                object.__setattr__(self, name, float(v))
            return
        try:
            shape = np.broadcast_shapes(*(np.shape(v) for v in values.values()))
        except ValueError:
            shapes = {k: np.shape(v) for k, v in values.items()}
            raise ValueError(f"State fields must broadcast to one shape; got {shapes}") from None
        for name, v in values.items():
            arr = np.broadcast_to(v, shape)
            object.__setattr__(self, name, float(arr) if arr.ndim == 0 else arr)

    @classmethod
    def unchecked(
        cls, theta: float, thetadot: float, phidot: float, omega3: float, nu_x: float, nu_y: float
    ) -> State:
        """A scalar State from values already known to be valid, without validating them.

        For states read off an integration (user events are evaluated at every solver step,
        where validating would cost more than the event). The caller guarantees what
        ``State(...)`` would check: finite floats and θ in [0, π] (rad); units as there.

        Parameters
        ----------
        theta, thetadot, phidot, omega3, nu_x, nu_y : float
            The fields of :class:`State` (rad, rad/s, m/s).
        """
        obj = object.__new__(cls)
        for name, value in zip(_FIELDS, (theta, thetadot, phidot, omega3, nu_x, nu_y), strict=True):
            object.__setattr__(obj, name, float(value))
        return obj

    @property
    def psidot(self) -> np.ndarray | float:
        """ψ̇ = ω3 − φ̇ cos θ."""
        return self.omega3 - self.phidot * np.cos(self.theta)

    @property
    def shape(self) -> tuple[int, ...]:
        theta = self.theta
        return () if type(theta) is float else np.shape(theta)  # one state: no numpy call

    def as_array(self) -> np.ndarray:
        """``[theta, thetadot, phidot, omega3, nu_x, nu_y]`` stacked on the first axis."""
        return np.array([getattr(self, name) for name in _FIELDS], dtype=float)

    @classmethod
    def from_array(cls, y: ArrayLike, *, name: str = "y") -> State:
        """Inverse of :meth:`as_array`.

        Parameters
        ----------
        y : array_like, shape (6, ...)
            ``[theta, thetadot, phidot, omega3, nu_x, nu_y]`` (rad, rad/s, m/s), real numbers.
        name : str, optional
            The argument's name in error messages (``"y"``; a caller passes its own).

        Raises
        ------
        TypeError
            If ``y`` holds strings, bytes, booleans, None or complex numbers (as for the fields
            of :class:`State`: ``np.asarray(y, dtype=float)`` would parse the strings, read
            booleans as 0/1 and drop imaginary parts).
        ValueError
            If the leading dimension is not 6, or a field is out of range (named).
        """
        y = _validate.real_array(name, y)
        if y.shape[:1] != (6,):
            raise ValueError(
                f"{name} must be a State or an array of leading dimension 6 "
                f"([theta, thetadot, phidot, omega3, nu_x, nu_y]); got shape {y.shape}"
            )
        return cls(*y)

    @classmethod
    def with_cm_at_rest(
        cls,
        top: TippeTop,
        theta: ArrayLike,
        omega3: ArrayLike,
        thetadot: ArrayLike = 0.0,
        phidot: ArrayLike = 0.0,
    ) -> State:
        """A state whose centre of mass has zero horizontal velocity.

        Then the contact point glides with ``v_A = ω × a`` (horizontal part), i.e.
        ``ν_x = −R θ̇ (1 − α cos θ)`` and ``ν_y = R sin θ (ω3 + φ̇ (α − cos θ))`` (docs/theory/model.md#conventions).
        With ``thetadot = 0`` the centre of mass is at rest.
        """
        _validate.instance("top", top, TippeTop)
        th = _validate.theta(theta)
        thetadot = _validate.as_finite_array("thetadot", thetadot)
        phidot = _validate.as_finite_array("phidot", phidot)
        omega3 = _validate.as_finite_array("omega3", omega3)
        c, s = np.cos(th), np.sin(th)
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused by State
            nu_x = -top.R * thetadot * (1.0 - top.alpha * c)
            nu_y = top.R * s * (omega3 + phidot * (top.alpha - c))
        return cls(theta=th, thetadot=thetadot, phidot=phidot, omega3=omega3, nu_x=nu_x, nu_y=nu_y)
