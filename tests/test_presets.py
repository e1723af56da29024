"""Presets: every preset builds a valid top; overrides; errors."""

from __future__ import annotations

import math

import pytest

import mett
from mett import presets


def test_names_are_the_documented_presets():
    assert presets.names() == (
        "cohen1977",
        "friedl1997",
        "maple-tippe-top",
        "rutstam2012",
        "rutstam2013",
        "ueda2005",
    )


@pytest.mark.parametrize("name", [n for n in presets.names() if n != "maple-tippe-top"])
def test_every_preset_builds_and_documents_its_source(name):
    top = presets.get(name)
    assert isinstance(top, mett.TippeTop)
    text = presets.describe(name)
    assert "source:" in text and "assumed:" in text


@pytest.mark.parametrize(
    ("name", "m", "R", "alpha", "f1", "f3"),
    [
        ("rutstam2013", 0.02, 0.02, 0.3, 131 / 350, 2 / 5),
        ("rutstam2012", 0.02, 0.02, 0.3, 47 / 125, 2 / 5),
        ("cohen1977", 0.015, 0.025, 0.2, 2 / 5, 2 / 5),
        ("ueda2005", 0.015, 0.015, 0.1, 2 / 5, 2 / 5),
    ],
)
def test_preset_values(name, m, R, alpha, f1, f3):
    top = presets.get(name)
    assert (top.m, top.R, top.alpha, top.mu, top.g) == (m, R, alpha, 0.3, 9.82)
    assert top.I1 == pytest.approx(f1 * m * R**2, rel=1e-14)
    assert top.I3 == pytest.approx(f3 * m * R**2, rel=1e-14)


def test_overrides_keep_inertia_fractions():
    top = presets.get("rutstam2013", m=0.04, mu=0.1)
    assert top.mu == 0.1
    assert top.I3 == pytest.approx(0.4 * 0.04 * 0.02**2)
    assert top.is_rational  # γ and σ do not depend on m when the fractions are kept
    fixed = presets.get("rutstam2013", I1=3e-6)
    assert fixed.I1 == 3e-6


def test_maple_tippe_top_needs_alpha_and_warns_about_its_inertia():
    with pytest.raises(ValueError, match="pass alpha"):
        presets.get("maple-tippe-top")
    with pytest.warns(mett.PhysicalityWarning):
        top = presets.get("maple-tippe-top", alpha=0.3)
    assert (top.m, top.R, top.I1, top.I3, top.g) == (0.013, 0.013, 4.5e-6, 5.0e-6, 9.81)
    assert top.gamma == pytest.approx(0.9)
    assert top.sigma == pytest.approx(0.4394, abs=1e-4)
    with pytest.warns(mett.PhysicalityWarning):
        via_a = presets.get("maple-tippe-top", a=0.0039)
    assert via_a.alpha == pytest.approx(0.3)


def test_maple_tippe_top_rational_eccentricity():
    # docs/maple-tippe-top-errata.md: σ = (1 − γ)/(γ + α² − 1) at α = 0.5724.
    with pytest.warns(mett.PhysicalityWarning):
        top = presets.get("maple-tippe-top", alpha=0.5724)
    assert top.sigma == pytest.approx(
        (1 - top.gamma) / (top.gamma + top.alpha**2 - 1), rel=5e-4
    )  # 0.5724 is rounded


def test_unknown_preset_lists_known_names():
    with pytest.raises(
        ValueError,
        match="unknown preset 'nope'; known presets: cohen1977, friedl1997, maple-tippe-top",
    ):
        presets.get("nope")


def test_unknown_override_is_refused():
    with pytest.raises(ValueError, match=r"unknown parameter\(s\) \['spin'\]"):
        presets.get("rutstam2013", spin=3.0)
    with pytest.raises(ValueError, match="either alpha or a"):
        presets.get("rutstam2013", alpha=0.3, a=0.006)


def test_friedl_stemmed_geometry_is_measured_from_the_centre_of_mass():
    # Friedl's (Leine & Glocker's) a1 = 3 mm and a2 = 16 mm are distances from the CM along the
    # axis, both on the ball's side: α = a1/r1 and ball centre to stem centre a2 − a1 = 13 mm
    top = presets.stemmed("friedl1997")
    assert isinstance(top, mett.stem.StemmedTop)
    b = top.ball
    assert (b.m, b.R, b.I1, b.I3) == (0.006, 0.015, 8e-7, 7e-7)
    assert b.R * b.alpha == pytest.approx(0.003, rel=1e-15)
    assert top.radius == 0.005
    assert b.R * b.alpha + top.distance == pytest.approx(0.016, rel=1e-15)  # CM to stem centre
    # the stem touches down where the two spheres' lowest points are level
    th = top.touchdown_angle
    assert b.R + top.distance * math.cos(th) == pytest.approx(top.radius, abs=1e-17)
    assert presets.get("friedl1997") == b
    assert presets.stemmed("friedl1997", mu=0.1).ball.mu == 0.1


def test_stemmed_needs_a_preset_with_a_stem():
    with pytest.raises(ValueError, match="preset 'rutstam2013' has no stem; presets with a stem"):
        presets.stemmed("rutstam2013")
    with pytest.raises(ValueError, match="unknown preset"):
        presets.stemmed("nope")
