"""The public functions of :mod:`mett.separation` and the per-element (scalar reference) path."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from .. import _validate
from ..potential import _check_integrals, d2V_dz2, dV_dz, g

if TYPE_CHECKING:
    from ..top import TippeTop
from ._exact import _shift
from ._quadrature import _phidot, _quadrature, _quadrature_vec, _small_oscillation_omega
from ._roots import _turning_point, _turning_points_vec
from ._wells import (
    _NEAR_POLE,
    _POLE_ABS,
    _POLE_LAYER,
    Band,
    _conditioning,
    _kinetic_at,
    _locate_wells,
    _near_pole_well,
    _pole_band,
    _pole_layer,
    _PoleForm,
    _steady_tolerance,
    _Well,
    _Wells,
    _wells,
)


def _refine_layer_ends(w: _Well, b: Band) -> Band:
    """Turning points in the layer of a pole re-solved in the pole form (:meth:`_PoleForm.root`).

    The z-form P is accurate to ~ε of its largest terms, a few ulps of z next to a pole; the
    distance u = 1 − p z from the pole is solved to full relative precision instead.
    """
    ends = [b.z_low, b.z_high]
    mid = 0.5 * (b.z_low + b.z_high)
    for i, layer in enumerate(_pole_layer(b)):
        z = ends[i]
        if layer and abs(z) < 1.0:
            p = 1.0 if z >= 0.0 else -1.0
            form = _PoleForm(w, p, at_pole=False)
            u_in = 1.0 - p * mid
            if not float(form.P(u_in)) > 0.0:
                continue
            zt = p * (1.0 - form.root(1.0 - p * z, u_in))
            ends[i] = zt if abs(zt) < 1.0 else math.nextafter(p, 0.0)
    return b._replace(z_low=ends[0], z_high=ends[1])


def _band_scalar(top: TippeTop, E: float, D: float, lam: float, z0: float | None) -> Band:
    w = _Well(top, E, D, lam)
    mins = _wells(w)
    candidates = []
    for zm in mins:
        if _near_pole_well(w, zm):
            candidates.append(_pole_band(w, zm))
            continue
        depth = w.excess(zm)
        tol, tol_in = (
            float(t)
            for t in _steady_tolerance(
                top, E, D, lam, w.Es, float(w.gravity(zm)), float(_kinetic_at(w, zm))
            )
        )
        if depth < -(tol + tol_in):
            candidates.append(Band("none", math.nan, math.nan, zm, depth))
        elif depth <= tol:
            candidates.append(Band("steady", zm, zm, zm, max(depth, 0.0)))
        else:
            w.set_reference(zm)
            try:
                z_low = _turning_point(w, -1.0, zm) if zm > -1.0 else -1.0
                z_high = _turning_point(w, 1.0, zm) if zm < 1.0 else 1.0
            except ValueError:
                # no sign change between the bottom and a pole: the band is below rounding
                candidates.append(Band("steady", zm, zm, zm, depth))
                continue
            candidates.append(_refine_layer_ends(w, Band("nutation", z_low, z_high, zm, depth)))
    live = [b for b in candidates if b.kind != "none"]
    if z0 is not None:
        for b in live:
            # Only selects the well: allow for the rounding of (E, D, λ) themselves, which moves
            # the turning points by ~ (rounding of the energy terms / depth) of the band width.
            slack = (b.z_high - b.z_low) * (1e-6 + _conditioning(top, E, D, lam, b.depth)) + 1e-12
            if b.z_low - slack <= z0 <= b.z_high + slack:
                return b
        raise ValueError(_z0_message(z0, E, D, lam))
    if len(live) > 1:
        # Several disjoint wells: the one the motion is in depends on the start.
        bands = ", ".join(f"[{b.z_low:.6g}, {b.z_high:.6g}]" for b in live)
        raise ValueError(f"V has several admissible bands {bands}; pass z0 to choose one")
    if live:
        return live[0]
    best = max(candidates, key=lambda b: b.depth)
    return best


def _start_energy(top: TippeTop, E: float, D: float, lam: float, z0: float) -> float | None:
    """Ẽ raised onto V(z0) when the start z0 lies outside the band only by the inputs' rounding.

    A start at rest in θ (a state) is a turning point: V(z0) = Ẽ exactly. Rounding E, D, λ to
    doubles moves Ẽ − V by up to ~8εS (:func:`_steady_tolerance`); at high spin that is more
    than the depth of the band, so the rounded triple can put z0 just outside its band, or leave
    no band at all. Within that bound the double nearest V(z0) (stepped up by ulps until the
    band holds z0) is returned, so that z0 is a turning point to one ulp of Ẽ; beyond it, None
    (inadmissible).
    """
    w = _Well(top, E, D, lam)
    excess = float(w.excess(z0))
    if not math.isfinite(excess) or excess >= 0.0:
        return None
    kin = float(_kinetic_at(w, z0))
    tol, tol_in = _steady_tolerance(top, E, D, lam, w.Es, float(w.gravity(z0)), kin)
    if -excess > float(tol + tol_in):
        return None
    raised = E - excess
    for _ in range(64):
        try:
            _band_scalar(top, raised, D, lam, z0)
            return raised
        except ValueError:
            raised = max(math.nextafter(raised, math.inf), raised + float(tol))
    return None


def _broadcast(E, D, lam, z0=None):
    E = _validate.as_finite_array("E", E)
    D = _validate.as_finite_array("D", D)
    lam = _validate.as_finite_array("lam", lam)
    if z0 is None:
        return [*np.broadcast_arrays(E, D, lam), None]
    z0 = _validate.cos_theta(z0, "z0")
    return np.broadcast_arrays(E, D, lam, z0)


# --- the scalar reference implementation --------------------------------------------------
# One element at a time with scipy's brentq: the public functions below use the array path and
# come here only for elements it passes on (see _solve); the tests compare the two paths.


def _admissible(top: TippeTop, E, D, lam, z0) -> tuple[Band, _Well]:
    try:
        b = _band_scalar(top, E, D, lam, z0)
    except ValueError:
        e_start = None if z0 is None else _start_energy(top, E, D, lam, z0)
        if e_start is None:
            raise
        E = e_start
        b = _band_scalar(top, E, D, lam, z0)
    if b.kind == "none":
        raise ValueError(_no_motion_message(E, D, lam, b.depth, b.z_min))
    w = _Well(top, E, D, lam)
    w.set_reference(b.z_min)
    return b, w


def _map(fn, E, D, lam, z0):
    E, D, lam, z0 = _broadcast(E, D, lam, z0)
    zz = [None] * E.size if z0 is None else z0.ravel()
    res = [
        fn(float(e), float(dd), float(la), None if z is None else float(z))
        for e, dd, la, z in zip(E.ravel(), D.ravel(), lam.ravel(), zz, strict=True)
    ]
    arr = np.array(res, dtype=float)
    if E.ndim == 0:
        return float(arr[0]) if arr.ndim == 1 else arr[0]
    return arr.reshape(E.shape + arr.shape[1:])


def _reference_band(top: TippeTop, E, D, lam, *, z0=None) -> Band:
    """:func:`band`, one element at a time (scalar reference implementation)."""
    E, D, lam, z0 = _broadcast(E, D, lam, z0)
    out = [
        _band_scalar(top, float(e), float(dd), float(la), None if z0 is None else float(zz))
        for e, dd, la, zz in zip(
            E.ravel(),
            D.ravel(),
            lam.ravel(),
            [None] * E.size if z0 is None else z0.ravel(),
            strict=True,
        )
    ]
    if E.ndim == 0:
        return out[0]
    fields = list(zip(*out, strict=True))
    return Band(
        np.array(fields[0], dtype=object).reshape(E.shape),
        *(np.array(col, dtype=float).reshape(E.shape) for col in fields[1:]),
    )


def _reference_f(top: TippeTop, z, E, D, lam) -> np.ndarray:
    """:func:`f`, one element at a time (scalar reference implementation)."""
    z = _validate.cos_theta(z)
    E, D, lam, _ = _broadcast(E, D, lam)
    z, E, D, lam = np.broadcast_arrays(z, E, D, lam)
    out = np.empty(z.shape)
    for idx in np.ndindex(z.shape):
        w = _Well(top, float(E[idx]), float(D[idx]), float(lam[idx]))
        out[idx] = w.P(float(z[idx]))
    return out / g(top, z)


def _reference_turning_points(top: TippeTop, E, D, lam, *, z0=None) -> np.ndarray:
    """:func:`turning_points`, one element at a time (scalar reference implementation)."""
    return _map(lambda *args: _turning_points_one(top, *args), E, D, lam, z0)


def _reference_nutation_period(top: TippeTop, E, D, lam, *, z0=None) -> np.ndarray:
    """:func:`nutation_period`, one element at a time (scalar reference implementation)."""
    return _map(lambda *args: _period_one(top, *args), E, D, lam, z0)


def _reference_mean_precession(top: TippeTop, E, D, lam, *, z0=None) -> np.ndarray:
    """:func:`mean_precession`, one element at a time (scalar reference implementation)."""
    return _map(lambda *args: _precession_one(top, *args), E, D, lam, z0)


def _turning_points_one(top: TippeTop, E, D, lam, z0) -> tuple[float, float]:
    b, _ = _admissible(top, E, D, lam, z0)
    return (b.z_low, b.z_high)


def _band_and_well(top: TippeTop, E, D, lam, z0, b: Band | None) -> tuple[Band, _Well]:
    """The band (found, or the one given) and its well referenced to the band's bottom."""
    if b is None:
        return _admissible(top, E, D, lam, z0)
    w = _Well(top, E, D, lam)
    w.set_reference(b.z_min)
    return b, w


def _period_one(top: TippeTop, E, D, lam, z0, b: Band | None = None) -> float:
    b, w = _band_and_well(top, E, D, lam, z0, b)
    if b.kind == "steady":
        return 2.0 * math.pi / _small_oscillation_omega(top, b, w)
    return _quadrature(top, b, w)[0]


def _precession_one(top: TippeTop, E, D, lam, z0, b: Band | None = None) -> float:
    b, w = _band_and_well(top, E, D, lam, z0, b)
    if b.kind == "steady":
        if abs(b.z_min) == 1.0:
            return _PoleForm(w, b.z_min).phidot_limit()  # the limit of a band shrinking onto it
        return float(_phidot(top, w, b.z_min))
    T, integral = _quadrature(top, b, w, lambda z: _phidot(top, w, z))
    if math.isinf(T):
        return integral  # on the separatrix: the limit at the pole (_anchored_quadrature)
    return integral / T


_NONE, _STEADY, _NUTATION = 0, 1, 2
_KINDS = np.array(["none", "steady", "nutation"], dtype=object)


def _z0_message(z0, E, D, lam) -> str:
    return (
        f"no admissible motion through z0 = {z0!r} for (E, D, lam) = ({E!r}, {D!r}, {lam!r}): "
        "E is below V(z0)"
    )


def _no_motion_message(E, D, lam, depth, z_min) -> str:
    return (
        f"(E, D, lam) = ({E!r}, {D!r}, {lam!r}) admits no motion: E lies "
        f"{-depth:.3g} J below the minimum of V (at z = {z_min:.6g}); need E >= min V"
    )


class _Solution(NamedTuple):
    """Flat results of :func:`_solve` (broadcast shape ``shape``)."""

    shape: tuple
    kind: np.ndarray  # _NONE, _STEADY, _NUTATION
    z_low: np.ndarray
    z_high: np.ndarray
    z_min: np.ndarray
    depth: np.ndarray
    value: np.ndarray  # period or mean precession (NaN if not asked for)
    errors: dict  # flat index -> (message, raised by band() too)
    scalar: np.ndarray  # elements computed by the scalar reference path


def _solve(top: TippeTop, E, D, lam, z0, quantity: str | None = None) -> _Solution:
    """Bands of all elements (and ``quantity``: "period" or "precession"), array path first."""
    _validate.instance("top", top, "TippeTop")
    E, D, lam, z0 = _broadcast(E, D, lam, z0)
    _check_integrals(top, E=E, D=D, lam=lam)
    shape = E.shape
    E, D, lam = (np.array(v, dtype=float).ravel() for v in (E, D, lam))
    z0 = None if z0 is None else np.array(z0, dtype=float).ravel()
    n = E.size
    kind = np.full(n, _NONE, dtype=np.int8)
    z_low, z_high, z_min, depth, value = (np.full(n, np.nan) for _ in range(5))
    errors: dict[int, tuple[str, bool]] = {}

    W = _Wells(top, E, D, lam)
    zm, vec = _locate_wells(W)
    near = vec & (1.0 - np.abs(zm) < _NEAR_POLE)
    k = np.flatnonzero(near)
    if k.size:  # wells hugging a pole: classified in the pole form (scalar path, _pole_band)
        vec[k] = (np.abs(zm[k]) == 1.0) & W.sub(k).n_vanishes(zm[k])
    v = np.flatnonzero(vec)
    Wv = W.sub(v)
    zmv = zm[v]
    dep = Wv.excess(zmv)
    tol, tol_in = _steady_tolerance(
        top, E[v], D[v], lam[v], Wv.Es, Wv.gravity(zmv), _kinetic_at(Wv, zmv)
    )
    kv = np.where(dep < -(tol + tol_in), _NONE, np.where(dep <= tol, _STEADY, _NUTATION))
    kind[v], z_min[v], depth[v] = kv, zmv, dep
    steady = v[kv == _STEADY]
    z_low[steady] = z_high[steady] = zm[steady]
    depth[steady] = np.maximum(depth[steady], 0.0)

    # Nutation: turning points (and the quadrature) for interior and pole references apart.
    nut = v[kv == _NUTATION]
    at_pole = np.abs(zm[nut]) == 1.0
    at_pole[at_pole] = W.sub(nut[at_pole]).n_vanishes(zm[nut[at_pole]])
    vec[nut[(np.abs(zm[nut]) == 1.0) & ~at_pole]] = False  # no reference: scalar path
    for k, pole_ref in ((nut[np.abs(zm[nut]) < 1.0], False), (nut[at_pole], True)):
        if k.size == 0:
            continue
        Wk = W.sub(k)
        Wk.set_reference(zm[k], pole_ref)
        zl, zh = np.full(k.size, -1.0), np.full(k.size, 1.0)
        good = np.ones(k.size, dtype=bool)
        for pole, zt in ((-1.0, zl), (1.0, zh)):
            j = np.flatnonzero(zm[k] != pole)
            zt[j], ok = _turning_points_vec(Wk.sub(j), pole, zm[k][j])
            good[j[~ok]] = False
        # bands ending in a boundary layer next to a pole go to the graded quadrature (scalar)
        half = 0.5 * (zh - zl)
        gap = np.maximum(_POLE_LAYER * half, _POLE_ABS)
        layer = (half >= 0.0) & ((1.0 - np.abs(zl) < gap) | (1.0 - np.abs(zh) < gap))
        good &= ~layer
        vec[k[~good]] = False
        z_low[k], z_high[k] = zl, zh
        if quantity is not None and np.any(good):
            j = np.flatnonzero(good)
            T, integral = _quadrature_vec(
                Wk.sub(j), zl[j], zh[j], zm[k[j]], precession=quantity == "precession"
            )
            value[k[j]] = T if integral is None else integral / T
    if quantity is not None:
        s = steady[vec[steady]]
        zs, Ds, lams = zm[s], D[s], lam[s]
        pole = np.abs(zs) == 1.0
        if quantity == "period":
            omega = np.empty(s.size)
            zi = zs[~pole]
            curv = d2V_dz2(top, zi, Ds[~pole], lams[~pole])
            omega[~pole] = np.sqrt((1.0 - zi * zi) * curv / (2.0 * g(top, zi)))
            slope = np.abs(dV_dz(top, zs[pole], Ds[pole], lams[pole]))
            omega[pole] = np.sqrt(2.0 * slope / g(top, zs[pole]))
            value[s] = 2.0 * math.pi / omega
        else:
            value[s[~pole]] = W.sub(s[~pole]).phidot(zs[~pole])
            # at a spinning pole: the limit of ⟨φ̇⟩ for a band shrinking onto it
            for i in s[pole]:
                w1 = _Well(top, float(E[i]), float(D[i]), float(lam[i]))
                value[i] = _PoleForm(w1, float(zm[i])).phidot_limit()

    # The start z0 must lie in the band (up to the conditioning of the band).
    if z0 is not None:
        live = v[(kind[v] != _NONE) & vec[v]]
        width = z_high[live] - z_low[live]
        slack = width * (1e-6 + _conditioning(top, E[live], D[live], lam[live], depth[live]))
        slack = slack + 1e-12
        inside = (z_low[live] - slack <= z0[live]) & (z0[live] <= z_high[live] + slack)
        bad = np.concatenate([v[(kind[v] == _NONE) & vec[v]], live[~inside]])
        for i in bad:
            vec[i] = False  # to the scalar path, which takes z0 as a turning point if it can
    else:
        for i in v[(kind[v] == _NONE) & vec[v]]:
            msg = _no_motion_message(float(E[i]), float(D[i]), float(lam[i]), depth[i], z_min[i])
            errors[i] = (msg, False)

    # Everything else: the scalar reference path, element by element.
    scalar = np.flatnonzero(~vec)
    for i in scalar:
        e, dd, la = float(E[i]), float(D[i]), float(lam[i])
        zz = None if z0 is None else float(z0[i])
        try:
            b = _band_scalar(top, e, dd, la, zz)
        except ValueError as exc:
            e_start = None if zz is None else _start_energy(top, e, dd, la, zz)
            if e_start is None:
                errors[i] = (str(exc), True)
                continue
            e = e_start
            b = _band_scalar(top, e, dd, la, zz)
        kind[i] = _KINDS.tolist().index(b.kind)
        z_low[i], z_high[i], z_min[i], depth[i] = b.z_low, b.z_high, b.z_min, b.depth
        if b.kind == "none":
            errors[i] = (_no_motion_message(e, dd, la, b.depth, b.z_min), False)
        elif quantity == "period":
            value[i] = _period_one(top, e, dd, la, zz, b)
        elif quantity == "precession":
            value[i] = _precession_one(top, e, dd, la, zz, b)
    return _Solution(shape, kind, z_low, z_high, z_min, depth, value, errors, ~vec)


def _raise_first(sol: _Solution, *, band_only: bool = False) -> None:
    """Raise the error of the first failing element (C order), as the element loop did."""
    bad = [i for i, (_, in_band) in sol.errors.items() if in_band or not band_only]
    if bad:
        raise ValueError(sol.errors[min(bad)][0])


def _shaped(sol: _Solution, arr: np.ndarray):
    return float(arr[0]) if sol.shape == () else arr.reshape(sol.shape)


# --- the public functions ---------------------------------------------------------------------


def band(
    top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike, *, z0: ArrayLike | None = None
) -> Band:
    """Classify the rolling θ-motion with integrals (Ẽ, D, λ) and find its band.

    Parameters
    ----------
    top : TippeTop
    E, D, lam : array_like
        Modified energy Ẽ (= E when rolling), Routh and Jellett integrals; broadcast together.
    z0 : array_like, optional
        A value of cos θ the motion passes through (e.g. the start), to pick the band when V has
        several wells. Without it, several admissible wells raise ``ValueError``.

    Returns
    -------
    Band
        Fields are arrays of the broadcast shape (floats for scalar input).
    """
    sol = _solve(top, E, D, lam, z0)
    _raise_first(sol, band_only=True)
    kinds = _KINDS[sol.kind]
    if sol.shape == ():
        return Band(str(kinds[0]), *(float(a[0]) for a in sol[2:6]))
    return Band(kinds.reshape(sol.shape), *(a.reshape(sol.shape) for a in sol[2:6]))


def classify_motion(top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray | str:
    """ "nutation", "steady" (bottom of the well) or "none" (no admissible motion); see :func:`band`."""
    return band(top, E, D, lam).kind


def f(top: TippeTop, z: ArrayLike, E: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray:
    """Right-hand side of ż² = f(z) = (1 − z²)(Ẽ − V(z, D, λ))/g(z) (docs/theory/mett.md#the-main-equation).

    Evaluated as P(z)/g(z) with the exact energy shift (module docstring), so it is finite at the
    poles and accurate where Ẽ − V is a small difference of large numbers.
    """
    _validate.instance("top", top, "TippeTop")
    z = _validate.cos_theta(z)
    E, D, lam, _ = _broadcast(E, D, lam)
    _check_integrals(top, E=E, D=D, lam=lam)
    Es = _shift(top, E, D, lam)
    z, E, D, lam, Es = np.broadcast_arrays(z, E, D, lam, Es)
    return _Wells(top, E, D, lam, Es).P_direct(z) / g(top, z)


def turning_points(
    top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike, *, z0: ArrayLike | None = None
) -> np.ndarray:
    """Turning points (z_low, z_high) of the rolling θ-motion: the roots of Ẽ = V(z, D, λ).

    Returns
    -------
    ndarray
        Shape ``broadcast_shape + (2,)``: ``[..., 0] = z_low <= [..., 1] = z_high``. For steady
        precession both equal the minimum of V. A pole is returned when the band reaches it (only
        possible when N vanishes there, i.e. D = D0 or D1).

    Raises
    ------
    ValueError
        If (E, D, λ) admits no motion (E below the minimum of V), or on bad input.

    Examples
    --------
    >>> import mett
    >>> top = mett.presets.get("rutstam2013")
    >>> s = mett.State(theta=1.0, omega3=100.0, phidot=5.0)
    >>> E, D, lam = mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s)
    >>> mett.turning_points(top, E, D, lam).round(6)
    array([0.540302, 0.613785])
    """
    sol = _solve(top, E, D, lam, z0)
    _raise_first(sol)
    return np.stack([sol.z_low, sol.z_high], axis=-1).reshape((*sol.shape, 2))


def nutation_period(
    top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike, *, z0: ArrayLike | None = None
) -> np.ndarray:
    """Exact period (s) of the θ-oscillation of the rolling top, T = 2∫ √(g/P) dz over the band.

    For steady precession (Ẽ at the bottom of the well) the small-oscillation limit
    2π/ω_θ, ω_θ² = (1 − z_m²) V''(z_m)/(2 g(z_m)), is returned (docs/theory/estimates.md#estimates).

    Raises
    ------
    ValueError
        If (E, D, λ) admits no motion, or on bad input.

    Examples
    --------
    The thesis body rolling from θ0 = 1 rad, ω3 = 100 rad/s, φ̇0 = 5 rad/s (docs/theory/mett.md#rational):

    >>> import mett
    >>> top = mett.presets.get("rutstam2013")
    >>> s = mett.State(theta=1.0, omega3=100.0, phidot=5.0)
    >>> T = mett.nutation_period(top, mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s))
    >>> round(float(T), 6)
    0.055014
    """
    sol = _solve(top, E, D, lam, z0, "period")
    _raise_first(sol)
    return _shaped(sol, sol.value)


def mean_precession(
    top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike, *, z0: ArrayLike | None = None
) -> np.ndarray:
    """Mean precession rate ⟨φ̇⟩ (rad/s) over one nutation period of the rolling top.

    ⟨φ̇⟩ = (2/T) ∫ φ̇(z) √(g/P) dz with φ̇(z) = N(z)/(R I1 (1 − z²)√d(z)); for steady precession
    the rate φ̇(z_min) itself.
    """
    sol = _solve(top, E, D, lam, z0, "precession")
    _raise_first(sol)
    return _shaped(sol, sol.value)
