"""Named parameter sets from the literature.

Each preset records its source and what had to be assumed. Inertias that the source gives as a
fraction of m R² stay that fraction when ``m`` or ``R`` is overridden (pass ``I1``/``I3`` explicitly to
fix them instead). Any preset accepts ``a`` (the CM offset αR, in metres) in place of ``alpha``.

>>> from mett import presets
>>> presets.names()
('cohen1977', 'friedl1997', 'maple-tippe-top', 'rutstam2012', 'rutstam2013', 'ueda2005')
>>> top = presets.get("rutstam2013", mu=0.1)
>>> real = presets.stemmed("friedl1997")   # the ball with its stem (a StemmedTop)
>>> round(real.distance, 3), round(real.touchdown_angle, 4)
(0.013, 2.4484)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from . import _validate
from .top import FIELD_RANGE, TippeTop

if TYPE_CHECKING:
    from .stem import StemmedTop

__all__ = ["Preset", "describe", "get", "names", "stemmed"]


@dataclass(frozen=True)
class Preset:
    """A named parameter set: defaults, the inertia rule, its source and assumptions."""

    name: str
    source: str
    assumptions: str
    defaults: dict[str, float | None]
    inertia: Callable[[float, float], tuple[float, float]] | None = None
    """(m, R) -> (I1, I3) when the source gives inertias as fractions of m R²."""
    stem: tuple[float, float] | None = None
    """(radius r_s, distance l_s) (m) of the stem sphere for :func:`stemmed`: its radius and
    the distance from the ball's centre to its centre along the axis; None without a stem."""


def _fractions(f1: float, f3: float) -> Callable[[float, float], tuple[float, float]]:
    return lambda m, R: (f1 * m * R * R, f3 * m * R * R)


_PRESETS: dict[str, Preset] = {
    p.name: p
    for p in (
        Preset(
            "rutstam2013",
            "N. Rutstam, Analysis of Dynamics of the Tippe Top, Linköping Dissertations 1500 (2013), "
            "table 1 first row and the simulation of §4/§8: m = 0.02 kg, R = 0.02 m, α = 0.3, "
            "I3 = 2/5 m R², I1 = 131/350 m R², μ = 0.3 s/m, g = 9.82 m/s².",
            "None. This body satisfies the rational condition exactly (γ = 131/140, σ = 5/2).",
            {"m": 0.02, "R": 0.02, "alpha": 0.3, "mu": 0.3, "g": 9.82},
            _fractions(131 / 350, 2 / 5),
        ),
        Preset(
            "rutstam2012",
            "N. Rutstam, Tippe top equations and equations for the related mechanical systems, SIGMA 8 "
            "(2012) 019, the V(cos θ, D) surface figure: thesis body with I1 = 47/125 m R².",
            "μ = 0.3 s/m and g = 9.82 m/s² as in the thesis. Not rational (algebraic V).",
            {"m": 0.02, "R": 0.02, "alpha": 0.3, "mu": 0.3, "g": 9.82},
            _fractions(47 / 125, 2 / 5),
        ),
        Preset(
            "cohen1977",
            "R. J. Cohen, The tippe top revisited, Am. J. Phys. 45 (1977) 12–17 (parameters as quoted "
            "in the secondary literature): m = 0.015 kg, R = 0.025 m, α = 0.2, I1 = I3 = 2/5 m R².",
            "μ = 0.3 s/m and g = 9.82 m/s² are ours: Cohen used Coulomb friction, which this "
            "viscous-type model does not reproduce.",
            {"m": 0.015, "R": 0.025, "alpha": 0.2, "mu": 0.3, "g": 9.82},
            _fractions(2 / 5, 2 / 5),
        ),
        Preset(
            "ueda2005",
            "T. Ueda, K. Sasaki, S. Watanabe, Motion of the tippe top: gyroscopic balance condition "
            "and stability, SIAM J. Appl. Dyn. Syst. 4 (2005) 1159–1194: m = 0.015 kg, R = 0.015 m, "
            "α = 0.1, I1 = I3 = 2/5 m R².",
            "μ = 0.3 s/m and g = 9.82 m/s² are ours (USW05 use a modified Coulomb law).",
            {"m": 0.015, "R": 0.015, "alpha": 0.1, "mu": 0.3, "g": 9.82},
            _fractions(2 / 5, 2 / 5),
        ),
        Preset(
            "friedl1997",
            "the dataset of C. Friedl (1997, thesis, Augsburg) as used by R. I. Leine and C. Glocker, A set-valued force law for spatial Coulomb-Contensou "
            "friction, Eur. J. Mech. A/Solids 22 (2003) 193-216: m = 6 g, I1 = 8e-7 kg m², "
            "I3 = 7e-7 kg m², ball radius r1 = 1.5 cm at a1 = 0.3 cm from the centre of mass, stem "
            "sphere r2 = 0.5 cm at a2 = 1.6 cm from the centre of mass, on the same side; Coulomb "
            "μ = 0.3, Contensou contact radius 5e-4 m; start θ0 = 0.1 rad, ψ̇0 = 180 rad/s.",
            "a1, a2 are distances from the centre of mass (their convention): α = a1/r1 = 0.2 and "
            "the ball-to-stem centre distance is a2 − a1 = 1.3 cm (stemmed(): with_stem(radius="
            "0.005, distance=0.013)), not 1.6 cm. μ = 0.3 here is the viscous law's (s/m), ours; "
            "their dry law is friction=Coulomb(0.3, contensou_radius=5e-4). g = 9.81 m/s².",
            {"m": 0.006, "R": 0.015, "alpha": 0.2, "I1": 8e-7, "I3": 7e-7, "mu": 0.3, "g": 9.81},
            stem=(0.005, 0.013),
        ),
        Preset(
            "maple-tippe-top",
            "Utilization of Maple-based Physics Computation in Determining the Dynamics of Tippe Top "
            "(no authors or year in the text; key from the title), Table 1 converted from CGS: I1 = 45 g cm² = 4.5e-6 "
            "kg m², I3 = 50 g cm² = 5.0e-6 kg m², m = 13 g, R = 1.3 cm (D = 2.6 cm is the diameter), "
            "g = 981 cm/s².",
            "The paper gives no eccentricity: alpha (or a = αR) must be passed. Its μ and its spin "
            "β₁ (Table 2, an initial condition here: ω3 = β₁/I3) are illegible; "
            "μ = 0.3 s/m is our default. Caveat: I3 > m R², so this is not a physical top "
            "(a PhysicalityWarning is emitted). Inversion needs α > 0.1; the rational case is "
            "α = 0.5724.",
            {
                "m": 0.013,
                "R": 0.013,
                "alpha": None,
                "I1": 4.5e-6,
                "I3": 5.0e-6,
                "mu": 0.3,
                "g": 9.81,
            },
        ),
    )
}


def names() -> tuple[str, ...]:
    """Names of the known presets, sorted."""
    return tuple(sorted(_PRESETS))


def _lookup(name: str) -> Preset:
    try:
        return _PRESETS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown preset {name!r}; known presets: {', '.join(names())}") from None


def describe(name: str) -> str:
    """Source and assumptions of a preset, as text."""
    p = _lookup(name)
    return f"{p.name}\n  source: {p.source}\n  assumed: {p.assumptions}"


def get(name: str, **overrides: Any) -> TippeTop:
    """The :class:`~mett.TippeTop` of preset ``name`` with ``overrides`` applied.

    Parameters
    ----------
    name : str
        One of :func:`names`.
    **overrides
        TippeTop fields (``m, R, alpha, I1, I3, mu, g``) or ``a`` (the CM offset αR in metres).

    Raises
    ------
    TypeError
        A value that is not a real number.
    ValueError
        Unknown preset or field, ``alpha`` missing where the source does not give it (maple-tippe-top), or
        nonphysical values.
    """
    p = _lookup(name)
    allowed = {"m", "R", "alpha", "I1", "I3", "mu", "g", "a"}
    unknown = set(overrides) - allowed
    if unknown:
        raise ValueError(
            f"unknown parameter(s) {sorted(unknown)} for preset {name!r}; "
            f"allowed: {', '.join(sorted(allowed))}"
        )
    params: dict[str, Any] = dict(p.defaults)
    overrides = dict(overrides)
    a = overrides.pop("a", None)
    params.update(overrides)
    # m and R enter a/R and the inertia fractions: check them first, so the error names them
    for field, unit in (("m", "kg"), ("R", "m")):
        params[field] = _validate.bounded_scalar(field, params[field], *FIELD_RANGE, unit=unit)
    if a is not None:
        if "alpha" in overrides:
            raise ValueError("give either alpha or a (= alpha*R), not both")
        a = _validate.finite_scalar("a", a)
        if not 0.0 < a < params["R"]:
            raise ValueError(f"a = alpha*R must lie in (0, R) = (0, {params['R']!r}) m; got {a!r}")
        params["alpha"] = a / params["R"]
    if params.get("alpha") is None:
        raise ValueError(
            f"preset {name!r} does not fix the eccentricity: pass alpha in (0, 1) or a = alpha*R "
            "(the source gives neither)"
        )
    if p.inertia is not None:
        I1, I3 = p.inertia(params["m"], params["R"])
        params.setdefault("I1", I1)
        params.setdefault("I3", I3)
    return TippeTop(**params)


def stemmed(name: str, **overrides: Any) -> StemmedTop:
    """The :class:`~mett.stem.StemmedTop` of a preset with a stem: :func:`get` (with
    ``overrides``) and the stem sphere the source gives.

    Raises
    ------
    ValueError
        Unknown preset, a preset without a stem (the error lists those with one), or what
        :func:`get` raises.
    """
    p = _lookup(name)
    if p.stem is None:
        with_stem = [n for n in names() if _PRESETS[n].stem is not None]
        raise ValueError(
            f"preset {name!r} has no stem; presets with a stem: {', '.join(with_stem)} "
            "(or give one: get(name).with_stem(radius, distance))"
        )
    radius, distance = p.stem
    return get(name, **overrides).with_stem(radius=radius, distance=distance)
