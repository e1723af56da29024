"""The emission of the Taylor jet (mett.dynamics.taylor): series products that share a factor,
written interleaved, give the jet of the mathematics and the very bits of the plain emission.

Independent reference: the Taylor coefficients of Jacobi's elliptic functions (whose equations
are three products sharing factors pairwise) from mpmath at 40 digits. Regression reference: the
gliding top's jet emitted product by product, the form the suite's accuracy tests validated.
"""

from __future__ import annotations

import ctypes

import mpmath
import numpy as np

import mett
from mett.dynamics import MODELS, taylor
from mett.dynamics.taylor import _codegen, _llvm

M_ELL = 0.5  # the parameter m of sn, cn, dn
T0 = 0.7  # where the series are taken (no symmetry makes coefficients vanish)
ORDER = 12


def _jacobi_into(t, y, p, out):
    # sn' = cn dn, cn' = −sn dn, dn' = −m sn cn (DLMF 22.13.1-3)
    out[0] = y[1] * y[2]
    out[1] = -(y[0] * y[2])
    out[2] = -p[0] * (y[0] * y[1])


def test_products_sharing_factors_are_emitted_together():
    """The Jacobi system's three products form one group (so the tests below exercise it)."""
    tr = taylor.trace(_jacobi_into, [], 3, 1)
    ir = _codegen._IR(tr, ORDER, "jacobi_groups", 1, _codegen._norm_groups((), 3))
    groups = ir.product_groups()
    assert len(groups) == 1 and len(next(iter(groups.values()))) == 3


def test_jacobi_jet_matches_mpmath_taylor_coefficients():
    """Coefficients 0..ORDER of sn, cn, dn at T0 against mpmath's (40 digits).

    Error analysis: |sn|, |cn|, |dn| ≤ 1 on the real line and the nearest poles lie K(1 − m) ≈ 1.85
    away, so every coefficient is O(1) and coefficient k is a sum of k + 1 products of such
    coefficients, each carrying the rounding of the k levels below it: its error is at most
    ~(k + 1)² ε. The bound used, 8 (k + 1)² ε, fails for any wrong term (those are O(0.1-1)).
    """
    mpmath.mp.dps = 40
    fns = [lambda t, f=f: mpmath.ellipfun(f, t, m=M_ELL) for f in ("sn", "cn", "dn")]
    y0 = [float(f(T0)) for f in fns]
    k = taylor.kernel(_jacobi_into, [], 3, 1, ORDER, "jacobi")
    C = taylor.solve(k, (0.0, 1e-300), y0, [M_ELL])[0].dense.C[0]  # one tiny step: its jet
    eps = np.finfo(float).eps
    for r, f in enumerate(fns):
        ref = mpmath.taylor(f, T0, ORDER)
        for j in range(ORDER + 1):
            err = abs(float(mpmath.mpf(C[r, j]) - ref[j]))
            assert err <= 8 * (j + 1) ** 2 * eps, (r, j, C[r, j], float(ref[j]))


def _call_jet(tr, order, lanes, vectors, interleave, y, p):
    """The coefficients X the compiled jet writes for states ``y`` and parameters ``p`` (lane-minor
    arrays), emitted with or without interleaving."""
    name = f"test_interleave_{order}x{lanes}_{int(interleave)}"
    ir = _codegen._IR(tr, order, name, lanes, vectors, interleave=interleave).text()
    fn = ctypes.CFUNCTYPE(None, *[ctypes.c_void_p] * 6)(_llvm._native(ir, name)[0])
    n, rows = tr.n_state, tr.n_state + len(tr.events)
    t0, sig, nrm = np.zeros(lanes), np.full((n + 1) * lanes, 1e-12), np.zeros(2 * lanes)
    X = np.full(rows * (order + 1) * lanes, np.nan)
    fn(t0.ctypes.data, y.ctypes.data, p.ctypes.data, X.ctypes.data, sig.ctypes.data,
       nrm.ctypes.data)  # fmt: skip
    return X, nrm


def test_interleaved_jet_is_bit_for_bit_the_plain_one():
    """The gliding top's jet at the sweep's order (15) on 4 lanes, four different states: the
    interleaved emission keeps every sum's terms and their order, so every coefficient and both
    step-size norms have the same bits as the product-by-product emission (a swapped or missing
    term changes them)."""
    mdl = MODELS["gliding"]
    top = mett.presets.get("rutstam2013")
    p = np.array(mdl.params(top, {}))
    states = [mett.State(theta=th, omega3=w) for th, w in ((0.1, 155.0), (1.2, 80.0), (2.5, 30.0))]
    Y = np.array([mdl.initial(s, tuple(p)) for s in states] + [mdl.initial(states[0], tuple(p))])
    Y[3, 2:4] += (0.3, -0.2)  # a sliding velocity in the fourth lane
    P = np.repeat(p[:, None], 4, axis=1)
    P[5] = (0.3, 0.1, 0.6, 0.2)  # μ per lane
    tr = taylor.trace(mdl.rhs_into, [ev.fn for ev in mdl.events], 10, 7, p, mdl.conserved_lengths)
    vectors = _codegen._norm_groups(mdl.vectors, 10)
    ir = _codegen._IR(tr, 15, "gliding_groups", 4, vectors)
    assert ir.product_groups()  # the gliding top does have products sharing factors
    y, pp = np.ascontiguousarray(Y.T).ravel(), np.ascontiguousarray(P).ravel()
    plain = _call_jet(tr, 15, 4, vectors, False, y, pp)
    inter = _call_jet(tr, 15, 4, vectors, True, y, pp)
    assert np.all(np.isfinite(plain[0]))
    for a, b in zip(plain, inter, strict=True):
        assert np.array_equal(a.view(np.uint64), b.view(np.uint64))
