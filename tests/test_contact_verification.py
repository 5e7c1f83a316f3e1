"""The tool contact against Hertz's line contact (solver/verification/contact_cases.py).

The tool's rounded edge, a rigid cylinder, pressed frictionlessly into an elastic block: the contact
half-width a measured from the nodal contact forces must approach Hertz's a^2 = 4 P R / (pi E*) at the
measured load as the penalty stiffens (a spring in series with the body widens the contact) and stay
within the case's 5 % once the penalty is stiff enough for the mesh. Measured (docs/validation.md,
"The tool's contact against Hertz"): errors 25 %, 10 %, 5.6 % at 3.4-3.7 elements across the
half-width for penalty factors 0.1, 0.3 and 1 (the default: k_i = 1.0 m_i / dt^2); 14 %, 6.2 %, 3.3 %
at 7-7.4 elements.
"""

import pytest

from solver.verification import load_cases

CASES = load_cases()


def hertz(**overrides):
    return CASES["tool-hertz"][0](overrides)


def test_the_hertz_case_is_registered():
    assert "tool-hertz" in CASES


def test_the_contact_width_approaches_hertz_as_the_penalty_stiffens():
    errors = [hertz(a_over_h=4, factor=f).error for f in (0.1, 0.3, 1.0)]
    assert errors[0] > errors[1] > errors[2], errors
    assert errors[2] < 0.08, errors  # the default penalty at 3.7 elements across the half-width


def test_the_contact_width_and_peak_pressure_match_hertz_on_a_finer_mesh():
    r = hertz(a_over_h=8)  # the default penalty
    assert r.passed, r.details  # a within 5 % of Hertz at the measured load
    d = r.details
    assert abs(d["p0_Pa"] / d["p0_hertz_Pa"] - 1) < 0.06, d  # p0 = 2 P / (pi a)
    assert d["kinetic_over_internal"] < 1e-6, d  # the block is at rest: a static answer
    assert d["max_penetration_fraction_of_element"] < 0.1, d


def test_a_bad_setting_names_itself():
    with pytest.raises(ValueError, match="a_over_h"):
        hertz(a_over_h=0.5)
    with pytest.raises(ValueError, match="unknown setting"):
        hertz(radius=1.0)
