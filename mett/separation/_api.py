"""The public functions of :mod:`mett.separation`, the array path (:func:`solve`) and the
per-element path for the elements it passes on (and the ``_reference_*`` functions the tests
compare with). Both run the same array algorithms, the per-element path on one element.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from .. import _formulas as fm
from .. import _validate
from ..top import TippeTop
from ._exact import _shift
from ._quadrature import _gauss_quadrature, _quadrature, _steady_values
from ._roots import _turning_points
from ._wells import (
    _NEAR_POLE,
    Band,
    _kinetic_at,
    _layer_ends,
    _locate_wells,
    _near_pole_well,
    _pole_band,
    _pole_layer,
    _PoleForm,
    _root_towards,
    _set_reference_one,
    _steady_tolerance,
    _well,
    _Wells,
    _wells,
    conditioning,
)

_NONE, _STEADY, _NUTATION = 0, 1, 2
_KINDS = np.array(["none", "steady", "nutation"], dtype=object)


# --- steps shared by the array path and the per-element path --------------------------------------


def _classify(top: TippeTop, W: _Wells, zm) -> tuple[np.ndarray, np.ndarray]:
    """(kind, depth) of the well at z_m of each element: _NONE, _STEADY or _NUTATION, Ẽ − V(z_m).

    Ẽ below the well by more than the rounding bound (:func:`_steady_tolerance`) admits no motion;
    within the computed rounding of the depth it is steady; above it, a nutation band.
    """
    depth = W.excess(zm)
    tol, tol_in = _steady_tolerance(top, W.E, W.D, W.lam, W.Es, W.gravity(zm), _kinetic_at(W, zm))
    kind = np.where(depth < -(tol + tol_in), _NONE, np.where(depth <= tol, _STEADY, _NUTATION))
    return kind, depth


def _band_ends(W: _Wells, zm) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(z_low, z_high, ok) of nutation bands about their wells' bottoms z_m (W referenced there).

    ok is False where a turning point has no sign change of P between z_m and the pole: the band
    is below rounding (steady).
    """
    zl, zh = np.full(zm.size, -1.0), np.full(zm.size, 1.0)
    ok = np.ones(zm.size, dtype=bool)
    for pole, zt in ((-1.0, zl), (1.0, zh)):
        j = np.flatnonzero(zm != pole)
        zt[j], good = _turning_points(W.sub(j), pole, zm[j])
        ok[j[~good]] = False
    return zl, zh, ok


def _holds_start(top: TippeTop, E, D, lam, z_low, z_high, depth, z0):
    """Whether the start z0 lies in the band, up to the rounding of (E, D, λ) themselves, which
    moves the turning points by ~ (rounding of the energy terms / depth) of the band width."""
    slack = (z_high - z_low) * (1e-6 + conditioning(top, E, D, lam, depth)) + 1e-12
    return (z_low - slack <= z0) & (z0 <= z_high + slack)


# --- the per-element path ----------------------------------------------------------------------


def _refine_layer_ends(w: _Wells, b: Band) -> Band:
    """Turning points in the layer of a pole re-solved in the pole form (:meth:`_PoleForm.root`).

    The z-form P is accurate to ~ε of its largest terms, a few ulps of z next to a pole; the
    distance u = 1 − p z from the pole is solved to full relative precision instead.
    """
    ends = [b.z_low, b.z_high]
    mid = 0.5 * (b.z_low + b.z_high)
    for i, layer in enumerate(_pole_layer(b)):
        z = ends[i]
        # an end at a pole where N does not vanish is a wall a few ulps off it (brentq's
        # tolerance in z is 4 ulps): re-solved as well
        if layer and (abs(z) < 1.0 or not w.n_vanishes(z)):
            p = 1.0 if z >= 0.0 else -1.0
            form = _PoleForm(w, p, at_pole=False)
            u_in = 1.0 - p * mid
            if not float(form.P(u_in)) > 0.0:
                continue
            if abs(z) < 1.0:
                u_t = form.root(1.0 - p * z, u_in)
            elif float(form.P(0.0)) < 0.0:
                u_t = _root_towards(form.P, 0.0, u_in)
            else:
                continue
            zt = p * (1.0 - u_t)
            ends[i] = zt if abs(zt) < 1.0 else math.nextafter(p, 0.0)
    return b._replace(z_low=ends[0], z_high=ends[1])


def _well_band(top: TippeTop, w: _Wells, zm: float) -> Band:
    """The band of one element's well at z_m (a hair off a pole: in the pole form)."""
    if _near_pole_well(w, zm):
        return _pole_band(w, zm)
    kind, depth = (float(v) for v in _classify(top, w, zm))
    if kind == _NONE:
        return Band("none", math.nan, math.nan, zm, depth)
    if kind == _STEADY:
        return Band("steady", zm, zm, zm, max(depth, 0.0))
    # not next to a pole: an interior reference, or a pole where N vanishes
    w.set_reference(zm, abs(zm) == 1.0)
    zl, zh, ok = _band_ends(w, np.array([zm]))
    if not ok[0]:  # no sign change between the bottom and a pole: the band is below rounding
        return Band("steady", zm, zm, zm, depth)
    return _refine_layer_ends(w, Band("nutation", float(zl[0]), float(zh[0]), zm, depth))


def _band_scalar(top: TippeTop, E: float, D: float, lam: float, z0: float | None) -> Band:
    """The band of one element; with z0, the one holding z0 (ValueError if none does)."""
    w = _well(top, E, D, lam)
    candidates = [_well_band(top, w, zm) for zm in _wells(w)]
    live = [b for b in candidates if b.kind != "none"]
    if z0 is not None:
        for b in live:
            # Only selects the well: allow for the rounding of (E, D, λ) themselves.
            if _holds_start(top, E, D, lam, b.z_low, b.z_high, b.depth, z0):
                return b
        raise ValueError(_z0_message(z0, E, D, lam))
    if len(live) > 1:
        # Several disjoint wells: the one the motion is in depends on the start.
        bands = ", ".join(f"[{b.z_low:.6g}, {b.z_high:.6g}]" for b in live)
        raise ValueError(f"V has several admissible bands {bands}; pass z0 to choose one")
    if live:
        return live[0]
    return max(candidates, key=lambda b: b.depth)


def _start_energy(top: TippeTop, E: float, D: float, lam: float, z0: float) -> float | None:
    """Ẽ raised onto V(z0) when the start z0 lies outside the band only by the inputs' rounding.

    A start at rest in θ (a state) is a turning point: V(z0) = Ẽ exactly. Rounding E, D, λ to
    doubles moves Ẽ − V by up to ~8εS (:func:`_steady_tolerance`); at high spin that is more
    than the depth of the band, so the rounded triple can put z0 just outside its band, or leave
    no band at all. Within that bound the double nearest V(z0) (stepped up by ulps until the
    band holds z0) is returned, so that z0 is a turning point to one ulp of Ẽ; beyond it, None
    (inadmissible).
    """
    w = _well(top, E, D, lam)
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


def _band_one(top: TippeTop, E: float, D: float, lam: float, z0) -> tuple[Band, float]:
    """(band, Ẽ used): :func:`_band_scalar`, with Ẽ raised onto V(z0) where the start lies outside
    the band only by the inputs' rounding (:func:`_start_energy`). ValueError as _band_scalar."""
    try:
        return _band_scalar(top, E, D, lam, z0), E
    except ValueError:
        e_start = None if z0 is None else _start_energy(top, E, D, lam, z0)
        if e_start is None:
            raise
        return _band_scalar(top, e_start, D, lam, z0), e_start


def _value_one(
    top: TippeTop, E: float, D: float, lam: float, b: Band, quantity: str, z0=None
) -> float:
    """Period or mean precession of one element's band (steady or nutation).

    With a start z0 at an end of the band on a pole where N vanishes to rounding and Ẽ = V(z0)
    within the rounding of the inputs, the start is at rest on that (unstable) pole, as a state
    there is (:func:`_start_energy`): the separatrix, (inf, the pole's φ̇). Otherwise the doubles
    (Ẽ, D, λ) are taken as exact, and their period is finite however close to the separatrix.
    """
    w = _well(top, E, D, lam)
    if b.kind == "steady":
        return float(_steady_values(top, w, np.array([b.z_min]), quantity)[0])
    if z0 is not None and abs(z0) == 1.0 and z0 in (b.z_low, b.z_high):
        form = _PoleForm(w, z0)  # N(z0) set to 0 where it vanishes to rounding (or underflows)
        tol, tol_in = _steady_tolerance(top, E, D, lam, w.Es, float(w.gravity(z0)), 0.0)
        if form.N_p == 0.0 and abs(form.A) <= float(tol + tol_in):
            return math.inf if quantity == "period" else form.phidot_limit()
    _set_reference_one(w, b.z_min)
    T, integral = _quadrature(top, b, w, quantity == "precession")
    if quantity == "period":
        return T
    if math.isinf(T):
        return integral  # on the separatrix: the limit at the pole (_anchored_quadrature)
    return integral / T


def band_average(
    top: TippeTop, E: float, D: float, lam: float, weight, z0: float | None = None
) -> tuple[Band, float, np.ndarray]:
    """Time averages ⟨F⟩ = ∮ F dt / T over one period of the rolling θ-motion with integrals (Ẽ, D, λ).

    ∮ F dt = 2 ∫ F(z) √(g(z)/P(z)) dz over the band, by the same quadrature as
    :func:`nutation_period` (the turning points' inverse square roots removed by the change of
    variable), so that ⟨1⟩ = 1 to rounding.

    Parameters
    ----------
    top : TippeTop
    E, D, lam : float
        Ẽ (J), D (kg m² s⁻¹), λ (kg m³ s⁻¹); one element.
    weight : callable
        F(z) for an array z of nodes in the band: an array of shape (q, *z.shape) (q quantities
        averaged at once).
    z0 : float, optional
        A point of the band (selects the well where V has several).

    Returns
    -------
    (Band, float, ndarray)
        The band, its period T (s; ``inf`` on a separatrix, where ⟨F⟩ is F at the pole) and ⟨F⟩
        (shape (q,)). A steady band gives F at the bottom of the well and the small-oscillation period.

    Raises
    ------
    ValueError
        As :func:`band`: (Ẽ, D, λ) admit no motion, or z0 lies in no band.
    TypeError
        If ``weight`` is not callable.
    """
    if not callable(weight):
        raise TypeError(f"weight must be a callable F(z); got {type(weight).__name__}")
    E, D, lam = (_validate.finite_scalar(n, v) for n, v in (("E", E), ("D", D), ("lam", lam)))
    b, E = _band_one(top, E, D, lam, z0)
    if b.kind == "none":
        raise ValueError(_no_motion_message(E, D, lam, b.depth, b.z_min))
    w = _well(top, E, D, lam)
    if b.kind == "steady":
        T = float(_steady_values(top, w, np.array([b.z_min]), "period")[0])
        return b, T, np.asarray(weight(np.array([b.z_min])))[..., 0]
    _set_reference_one(w, b.z_min)
    T, integral = _quadrature(top, b, w, weight)
    return b, T, integral if math.isinf(T) else integral / T


def _broadcast(E, D, lam, z0=None):
    E = _validate.as_finite_array("E", E)
    D = _validate.as_finite_array("D", D)
    lam = _validate.as_finite_array("lam", lam)
    if z0 is None:
        return [*np.broadcast_arrays(E, D, lam), None]
    z0 = _validate.cos_theta(z0, "z0")
    return np.broadcast_arrays(E, D, lam, z0)


# --- the scalar reference implementation --------------------------------------------------
# One element at a time: the public functions below use the array path and come here only for
# elements it passes on (see solve); the tests compare the two paths.


def _elements(E, D, lam, z0):
    """(shape, [(E, D, λ, z0 or None) as floats for each element in C order])."""
    E, D, lam, z0 = _broadcast(E, D, lam, z0)
    zz = [None] * E.size if z0 is None else [float(z) for z in z0.ravel()]
    rows = zip(E.ravel().tolist(), D.ravel().tolist(), lam.ravel().tolist(), zz, strict=True)
    return E.shape, list(rows)


def _admissible(top: TippeTop, E, D, lam, z0) -> Band:
    b, E = _band_one(top, E, D, lam, z0)
    if b.kind == "none":
        raise ValueError(_no_motion_message(E, D, lam, b.depth, b.z_min))
    return b


def _map(fn, E, D, lam, z0):
    shape, rows = _elements(E, D, lam, z0)
    arr = np.array([fn(*row) for row in rows], dtype=float)
    if shape == ():
        return float(arr[0]) if arr.ndim == 1 else arr[0]
    return arr.reshape(shape + arr.shape[1:])


def _reference_band(top: TippeTop, E, D, lam, *, z0=None) -> Band:
    """:func:`band`, one element at a time (scalar reference implementation)."""
    shape, rows = _elements(E, D, lam, z0)
    out = [_band_scalar(top, *row) for row in rows]
    if shape == ():
        return out[0]
    fields = list(zip(*out, strict=True))
    return Band(
        np.array(fields[0], dtype=object).reshape(shape),
        *(np.array(col, dtype=float).reshape(shape) for col in fields[1:]),
    )


def _reference_f(top: TippeTop, z, E, D, lam) -> np.ndarray:
    """:func:`f`, one element at a time (scalar reference implementation)."""
    z = _validate.cos_theta(z)
    E, D, lam, _ = _broadcast(E, D, lam)
    z, E, D, lam = np.broadcast_arrays(z, E, D, lam)
    out = np.empty(z.shape)
    for idx in np.ndindex(z.shape):
        out[idx] = _well(top, E[idx], D[idx], lam[idx]).P(float(z[idx]))
    return out / fm.g(top, z)


def _reference_turning_points(top: TippeTop, E, D, lam, *, z0=None) -> np.ndarray:
    """:func:`turning_points`, one element at a time (scalar reference implementation)."""

    def one(e, dd, la, z):
        b = _admissible(top, e, dd, la, z)
        return (b.z_low, b.z_high)

    return _map(one, E, D, lam, z0)


def _reference_value(top: TippeTop, E, D, lam, z0, quantity: str) -> np.ndarray:
    def one(e, dd, la, z):
        b, e = _band_one(top, e, dd, la, z)
        if b.kind == "none":
            raise ValueError(_no_motion_message(e, dd, la, b.depth, b.z_min))
        return _value_one(top, e, dd, la, b, quantity, z)

    return _map(one, E, D, lam, z0)


def _reference_nutation_period(top: TippeTop, E, D, lam, *, z0=None) -> np.ndarray:
    """:func:`nutation_period`, one element at a time (scalar reference implementation)."""
    return _reference_value(top, E, D, lam, z0, "period")


def _reference_mean_precession(top: TippeTop, E, D, lam, *, z0=None) -> np.ndarray:
    """:func:`mean_precession`, one element at a time (scalar reference implementation)."""
    return _reference_value(top, E, D, lam, z0, "precession")


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


# --- the array path ---------------------------------------------------------------------------


class _Solution(NamedTuple):
    """Flat results of :func:`solve` (broadcast shape ``shape``)."""

    shape: tuple
    kind: np.ndarray  # _NONE, _STEADY, _NUTATION
    z_low: np.ndarray
    z_high: np.ndarray
    z_min: np.ndarray
    depth: np.ndarray
    value: np.ndarray  # period or mean precession (NaN if not asked for)
    errors: dict  # flat index -> (message, raised by band() too)
    scalar: np.ndarray  # elements computed by the per-element path


def solve(top: TippeTop, E, D, lam, z0, quantity: str | None = None) -> _Solution:
    """Bands of all elements (and ``quantity``: "period" or "precession"), array path first.

    The steps: validate and flatten; locate the wells; classify them; turning points (and the
    quadrature) of the nutation bands; the steady values; check the start; and every element the
    array path passes on (several wells, a well next to a pole, a band in a pole's layer, a start
    outside its band) element by element.
    """
    shape, E, D, lam, z0 = _flat_inputs(top, E, D, lam, z0)
    n = E.size
    kinds = np.full(n, _NONE, dtype=np.int8)

    def nan() -> np.ndarray:
        return np.full(n, np.nan)

    sol = _Solution(shape, kinds, nan(), nan(), nan(), nan(), nan(), {}, np.zeros(n, bool))
    W = _Wells(top, E, D, lam)
    zm, vec = _array_wells(W)
    v = np.flatnonzero(vec)
    kind, depth = _classify(top, W.sub(v), zm[v])
    sol.kind[v], sol.z_min[v], sol.depth[v] = kind, zm[v], depth
    steady = v[kind == _STEADY]
    sol.z_low[steady] = sol.z_high[steady] = zm[steady]
    sol.depth[steady] = np.maximum(sol.depth[steady], 0.0)
    _nutation_bands(W, v[kind == _NUTATION], zm, vec, sol, quantity)
    if quantity is not None:
        s = steady[vec[steady]]
        sol.value[s] = _steady_values(top, W.sub(s), zm[s], quantity)
    _check_start(top, E, D, lam, z0, v, vec, sol)
    sol.scalar[:] = ~vec
    for i in np.flatnonzero(~vec):
        _solve_one(top, E, D, lam, z0, i, sol, quantity)
    return sol


def _flat_inputs(top: TippeTop, E, D, lam, z0):
    """(shape, E, D, λ, z0): validated, bounded (:func:`mett._formulas.check_integrals`), flat."""
    _validate.instance("top", top, TippeTop)
    E, D, lam, z0 = _broadcast(E, D, lam, z0)
    fm.check_integrals(top, E=E, D=D, lam=lam)
    shape = E.shape
    E, D, lam = (np.array(v, dtype=float).ravel() for v in (E, D, lam))
    return shape, E, D, lam, None if z0 is None else np.array(z0, dtype=float).ravel()


def _array_wells(W: _Wells) -> tuple[np.ndarray, np.ndarray]:
    """(z_min, vec): the single well of each element; vec False for the per-element path (several
    wells or none, or a well hugging a pole where N does not vanish: classified in the pole form,
    :func:`_pole_band`)."""
    zm, vec = _locate_wells(W)
    k = np.flatnonzero(vec & (1.0 - np.abs(zm) < _NEAR_POLE))
    if k.size:
        vec[k] = (np.abs(zm[k]) == 1.0) & W.sub(k).n_vanishes(zm[k])
    return zm, vec


def _nutation_bands(W: _Wells, nut, zm, vec, sol: _Solution, quantity) -> None:
    """Turning points (and the quadrature) of the nutation bands ``nut``, in place.

    Interior and pole references apart; a well at a pole where N does not vanish has no reference,
    and bands ending in the layer of a pole go to the graded quadrature about it: both to the
    per-element path (vec False).
    """
    zn = zm[nut]
    at_pole = np.abs(zn) == 1.0
    at_pole[at_pole] = W.sub(nut[at_pole]).n_vanishes(zn[at_pole])
    vec[nut[(np.abs(zn) == 1.0) & ~at_pole]] = False
    for k, pole_ref in ((nut[np.abs(zn) < 1.0], False), (nut[at_pole], True)):
        if k.size == 0:
            continue
        Wk = W.sub(k)
        Wk.set_reference(zm[k], pole_ref)
        zl, zh, good = _band_ends(Wk, zm[k])
        low, high = _layer_ends(zl, zh)
        good &= ~(low | high)
        vec[k[~good]] = False
        sol.z_low[k], sol.z_high[k] = zl, zh
        j = np.flatnonzero(good)
        if quantity is not None and j.size:
            T, integral = _gauss_quadrature(
                Wk.sub(j), zl[j], zh[j], zm[k[j]], quantity == "precession"
            )
            sol.value[k[j]] = T if integral is None else integral / T


def _check_start(top: TippeTop, E, D, lam, z0, v, vec, sol: _Solution) -> None:
    """With z0: elements whose start lies outside their band (up to its conditioning) or that
    admit no motion go to the per-element path, which takes z0 as a turning point if it can.
    Without: "no motion" errors for the elements that admit none."""
    none = v[(sol.kind[v] == _NONE) & vec[v]]
    if z0 is None:
        for i in none:
            msg = _no_motion_message(
                E[i].item(), D[i].item(), lam[i].item(), sol.depth[i], sol.z_min[i]
            )
            sol.errors[i] = (msg, False)
        return
    live = v[(sol.kind[v] != _NONE) & vec[v]]
    zl, zh, depth = sol.z_low[live], sol.z_high[live], sol.depth[live]
    inside = _holds_start(top, E[live], D[live], lam[live], zl, zh, depth, z0[live])
    vec[none] = False
    vec[live[~inside]] = False


def _solve_one(top: TippeTop, E, D, lam, z0, i: int | np.integer, sol: _Solution, quantity) -> None:
    """Element i by the per-element path, in place (its error recorded, not raised)."""
    e, dd, la = E[i].item(), D[i].item(), lam[i].item()
    zz = None if z0 is None else z0[i].item()
    try:
        b, e = _band_one(top, e, dd, la, zz)
    except ValueError as exc:
        sol.errors[i] = (str(exc), True)
        return
    sol.kind[i] = _KINDS.tolist().index(b.kind)
    sol.z_low[i], sol.z_high[i], sol.z_min[i], sol.depth[i] = b.z_low, b.z_high, b.z_min, b.depth
    if b.kind == "none":
        sol.errors[i] = (_no_motion_message(e, dd, la, b.depth, b.z_min), False)
    elif quantity is not None:
        sol.value[i] = _value_one(top, e, dd, la, b, quantity, zz)


def raise_first(sol: _Solution, *, band_only: bool = False) -> None:
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
    sol = solve(top, E, D, lam, z0)
    raise_first(sol, band_only=True)
    kinds = _KINDS[sol.kind]
    z_low, z_high, z_min, depth = sol.z_low, sol.z_high, sol.z_min, sol.depth
    if sol.shape == ():
        return Band(
            str(kinds[0]), float(z_low[0]), float(z_high[0]), float(z_min[0]), float(depth[0])
        )
    # arrays of the broadcast shape in the fields (Band annotates one element's types)
    arrays: list[Any] = [a.reshape(sol.shape) for a in (kinds, z_low, z_high, z_min, depth)]
    return Band(*arrays)


def minima(top: TippeTop, D: float, lam: float) -> list[float]:
    """Positions z = cos θ of the local minima of V(·, D, λ) on [−1, 1], ascending (scalar D, λ).

    Found from the sign changes of the regular numerator (1 − z²)² ∂V/∂z on a grid denser towards
    the poles, each refined to full precision; a pole is a minimum when V decreases towards it
    (possible only where N vanishes there, D = D0 or D1), and a minimum at a pole where N does not
    vanish is returned as the float next to it (V is +inf at the pole itself).
    """
    _validate.instance("top", top, TippeTop)
    D = _validate.finite_scalar("D", D)
    lam = _validate.finite_scalar("lam", lam)
    fm.check_integrals(top, D=np.asarray(D), lam=np.asarray(lam))
    # The energy does not move the minima; 0 keeps the shift finite.
    return _wells(_well(top, 0.0, D, lam))


def classify_motion(top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray | str:
    """ "nutation", "steady" (bottom of the well) or "none" (no admissible motion); see :func:`band`."""
    return band(top, E, D, lam).kind


def f(top: TippeTop, z: ArrayLike, E: ArrayLike, D: ArrayLike, lam: ArrayLike) -> np.ndarray:
    """Right-hand side of ż² = f(z) = (1 − z²)(Ẽ − V(z, D, λ))/g(z) (docs/theory/mett.md#the-main-equation).

    Evaluated as P(z)/g(z) with the exact energy shift (module docstring), so it is finite at the
    poles and accurate where Ẽ − V is a small difference of large numbers.
    """
    _validate.instance("top", top, TippeTop)
    z = _validate.cos_theta(z)
    Eb, Db, lamb, _ = _broadcast(E, D, lam)
    fm.check_integrals(top, E=Eb, D=Db, lam=lamb)
    Es = _shift(top, Eb, Db, lamb)
    z, E, D, lam, Es = np.broadcast_arrays(z, Eb, Db, lamb, Es)
    return _Wells(top, E, D, lam, Es).P_direct(z) / fm.g(top, z)


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
    sol = solve(top, E, D, lam, z0)
    raise_first(sol)
    return np.stack([sol.z_low, sol.z_high], axis=-1).reshape((*sol.shape, 2))


def nutation_period(
    top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike, *, z0: ArrayLike | None = None
) -> np.ndarray:
    """Exact period (s) of the θ-oscillation of the rolling top, T = 2∫ √(g/P) dz over the band.

    For steady precession (Ẽ at the bottom of the well) the small-oscillation limit
    2π/ω_θ, ω_θ² = (1 − z_m²) V''(z_m)/(2 g(z_m)), is returned (docs/theory/estimates.md#estimates),
    at the true bottom z_m of the well, also where it lies below one ulp of z from a pole (a
    vanishing spin); on a spinning pole its limit ω_θ² = 2|V'(±1)|/g(±1).

    The doubles (E, D, λ) are taken as exact: next to the separatrix of an unstable pole the
    period is finite and exact down to one ulp of Ẽ from V(±1); it is inf only on the separatrix
    itself (Ẽ = V(±1) and N(±1) = 0 exactly, or a start ``z0`` at rest on the pole, Ẽ = V(z0)
    within the rounding of the inputs). See docs/reliability.md.

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
    sol = solve(top, E, D, lam, z0, "period")
    raise_first(sol)
    return _shaped(sol, sol.value)


def mean_precession(
    top: TippeTop, E: ArrayLike, D: ArrayLike, lam: ArrayLike, *, z0: ArrayLike | None = None
) -> np.ndarray:
    """Mean precession rate ⟨φ̇⟩ (rad/s) over one nutation period of the rolling top.

    ⟨φ̇⟩ = (2/T) ∫ φ̇(z) √(g/P) dz with φ̇(z) = N(z)/(R I1 (1 − z²)√d(z)); for steady precession
    the rate φ̇(z_min) itself.

    Notes
    -----
    A band that reaches a pole where N(±1) is zero to rounding (within 64 ulps of its terms λ√d
    and R D(α ∓ 1): D = D0 or D1 rounded to a double, a state on the axis) passes through the
    vertical, where the precession angle jumps by ±π with the sign of N(±1), which the rounding
    of the inputs does not fix. The value returned leaves the jump out: it is the mean of the two
    one-sided values, and continuous with the steady spin at the pole (the limit of the bands
    shrinking onto it, returned for that steady spin). Taking the doubles (E, D, λ) as exact, with
    N(±1) ≠ 0, the mean precession is this value plus sign(N(±1)) π/T for each pole the band
    reaches (checked against a 60-digit quadrature to 1e-12 of π/T), or ± π/T of the
    small-oscillation period for the steady spin; where the band is itself only a few ulps wide
    (a start within ~1e-7 rad of a pole at high spin) the exact inputs also reshape it.
    """
    sol = solve(top, E, D, lam, z0, "precession")
    raise_first(sol)
    return _shaped(sol, sol.value)
