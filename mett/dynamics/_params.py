"""Named positions in the models' parameter tuples: one shared prefix order for every model.

Every registered model's tuple ``Model.parameters(top, **options)`` starts with the same seven
entries, in the order of the ``"gliding"`` model::

    (m, R, l, I1, I3, mu, g, ...)   with l = R α (m), or α itself (rad) in the Euler-angle forms

and a model appends its own entries after them (a tail). The kernels index the tuple by these
names (``p[ix.MU]``), never by number, so that ``g`` and ``mu`` cannot be swapped between models.
The names are module-level ints: numba freezes them into the compiled code as constants, and the
Taylor tracer indexes its symbolic tuple with them alike.

The tuples (positions after the prefix):

* vector models (``"gliding"``, ``"rolling"``, ``"gliding-hst"``): prefix only, ``L`` = R α
  (``"gliding-hst"`` has R = 0);
* Euler-angle forms (``"gliding-euler"``, ``"cylinder"``): prefix only, ``ALPHA`` = α;
* ``"frictionless-routhian"``: ``ALPHA`` = α, ``MU`` = 0 (no friction), ``VERTICAL`` (1 or 0);
* ``"stemmed"`` (viscous): ``R_S``, ``L_S``: the stem sphere's radius and the distance from the
  ball's centre to the stem sphere's centre along 3̂ (m);
* ``"stemmed-coulomb-regularised"``: the ``"stemmed"`` tuple with ``MU`` the law's μ, then
  ``STEM_EPS`` (regularisation speed ε, m/s);
* the dry models (``"coulomb"``, ``"coulomb-contensou"``, ``"coulomb-regularised"``): ``MU`` is
  the law's μ, then ``RSTAR`` (Contensou radius r*, m), ``EPS`` (regularisation speed, m/s),
  ``LAW`` (a law code of :mod:`.contact`), ``BAND`` (stopping band δ, m/s);
* the dry stemmed models (``"stemmed-coulomb"``, ``"stemmed-coulomb-contensou"``): the dry tuple
  and then ``DRY_R_S``, ``DRY_L_S``;
* ``"rolling-resistance"``: ``MU`` the viscous coefficient, then ``MU_R`` (rolling-resistance
  length, m) and ``W_EPS`` (regularisation rate of ω_h, rad/s).

Before this shared order the dry models, rolling resistance and the Routhian put ``g`` before
``mu`` (the Routhian had no ``mu``); :func:`from_legacy` maps such a saved tuple to this order, so
that files written before still load. The positions are part of the saved-file meaning: changing
one needs a new :func:`from_legacy` rule (and a cleared numba cache, which keys on the source file
of a kernel and not on this module).
"""

from __future__ import annotations

__all__ = [
    "ALPHA",
    "BAND",
    "DRY_L_S",
    "DRY_R_S",
    "EPS",
    "I1",
    "I3",
    "LAW",
    "L_S",
    "MU",
    "MU_R",
    "PREFIX",
    "RSTAR",
    "R_S",
    "STEM_EPS",
    "VERTICAL",
    "W_EPS",
    "G",
    "L",
    "M",
    "R",
    "from_legacy",
    "prefix",
]

# the shared prefix (m, R, l | alpha, I1, I3, mu, g)
M = 0  # mass m (kg)
R = 1  # radius R of the (ball's) sphere (m)
L = 2  # l = R alpha: centre of the sphere to the centre of mass along 3̂ (m), vector models
ALPHA = 2  # alpha = l/R (1): the same slot in the Euler-angle forms and the Routhian
I1 = 3  # transverse moment of inertia (kg m²)
I3 = 4  # axial moment of inertia (kg m²)
MU = 5  # friction coefficient: viscous (s/m) or the dry law's (1)
G = 6  # gravitational acceleration (m/s²)
PREFIX = 7  # length of the shared prefix

# "stemmed" (viscous): the stem sphere
R_S = 7  # stem sphere radius (m)
L_S = 8  # ball centre to stem sphere centre along 3̂ (m)
STEM_EPS = 9  # "stemmed-coulomb-regularised": regularisation speed epsilon (m/s)

# the dry-law tail (stickslip / contact)
RSTAR = 7  # Contensou radius r* (m); 0 without Contensou
EPS = 8  # regularisation speed (m/s) of the regularised law; 0 otherwise
LAW = 9  # law code: contact.LAW_COULOMB or contact.LAW_REGULARISED
BAND = 10  # stopping band delta (m/s)
DRY_R_S = 11  # the dry stemmed models: stem sphere radius (m)
DRY_L_S = 12  # and ball centre to stem sphere centre (m)

# "rolling-resistance"
MU_R = 7  # rolling-resistance length mu_r (m)
W_EPS = 8  # regularisation rate omega_eps (rad/s)

# "frictionless-routhian"
VERTICAL = 7  # 1.0: the centre of mass moves vertically only; 0.0: it moves freely


def prefix(p: tuple, mu: float | None = None) -> tuple:
    """The shared prefix (m, R, l, I1, I3, mu, g) of ``p``, with ``mu`` replaced if given.

    This is the parameter tuple of the ``"gliding"`` model (``mu=0.0``: frictionless gliding).
    """
    return (p[M], p[R], p[L], p[I1], p[I3], p[MU] if mu is None else mu, p[G])


# models whose tuple had g before mu (g at 5, mu at 6) before the shared order
_SWAPPED_G_MU = frozenset(
    {
        "coulomb",
        "coulomb-contensou",
        "coulomb-regularised",
        "stemmed-coulomb",
        "stemmed-coulomb-contensou",
        "rolling-resistance",
    }
)


def from_legacy(model: str, values: tuple) -> tuple | None:
    """``values`` saved in the order of before the shared prefix, in today's order (or None).

    The dry models and ``"rolling-resistance"`` had (m, R, l, I1, I3, g, mu, ...): g and mu are
    swapped back. ``"frictionless-routhian"`` had (m, R, alpha, I1, I3, g, vertical): mu = 0 is
    inserted. None for other models or a tuple of the wrong length.
    """
    v = tuple(values)
    if model in _SWAPPED_G_MU and len(v) > PREFIX:
        return (*v[:5], v[6], v[5], *v[7:])
    if model == "frictionless-routhian" and len(v) == 7:
        return (*v[:5], 0.0, v[5], v[6])
    return None
