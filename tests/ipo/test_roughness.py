"""002's roughness limiter against the worked check of algorithms.md §5 and a brute-force search."""
import numpy as np
import pytest

from ipo import roughness as rg

R, FP, TARGET, Z, S = 3.0, 0.2, 0.0033, 2, 12500.0


def test_worked_check_alpha_zero():
    fi = rg.feed_per_tooth_mm(R, FP, TARGET, 0.0)
    assert fi == pytest.approx(np.sqrt(2 * 3 * 0.0033 - 0.0033**2), rel=1e-12)
    assert fi == pytest.approx(0.1407, abs=5e-5)
    f_mm_min = rg.roughness_feed_mm_s(R, FP, TARGET, Z, S, 0.0) * 60
    assert f_mm_min == pytest.approx(3518, abs=2.0)  # 2 * 12500 * 0.14067 = 3516.8
    # steep: the no-tip regime, eq. 5, above the programmed 5000 mm/min
    f_steep = rg.roughness_feed_mm_s(R, FP, TARGET, Z, S, np.radians(30)) * 60
    assert f_steep == pytest.approx(2 * S * (FP / (2 * np.pi) + np.sqrt(8 * R * TARGET - FP**2)), rel=1e-12)
    assert f_steep > 5000


def _largest_fi_brute(alpha, target):
    """Largest f_i on a fine grid with model roughness <= target, refined by bisection."""
    f = np.linspace(1e-4, 1.0, 200001)
    ok = rg.rmax_mm(R, f, FP, alpha) <= target
    i = np.nonzero(ok)[0][-1]
    lo, hi = f[i], f[i + 1]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if rg.rmax_mm(R, mid, FP, alpha) <= target else (lo, mid)
    return lo


@pytest.mark.parametrize("alpha_deg", [0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 3.4, 3.6, 5.0, 20.0, 60.0, 89.0])
@pytest.mark.parametrize("target", [0.0033, 0.002, 0.006])
def test_limiter_matches_brute_force(alpha_deg, target):
    a = np.radians(alpha_deg)
    fi = rg.feed_per_tooth_mm(R, FP, target, a)
    assert fi == pytest.approx(_largest_fi_brute(a, target), rel=1e-6)
    assert rg.rmax_mm(R, fi, FP, a) <= target * (1 + 1e-9)


def test_regimes_agree_at_critical_angle():
    fi = np.linspace(0.12, 0.4, 50)  # above ~0.11 mm the critical angle exists (eq. 4 real)
    ac = rg.critical_alpha_rad(R, fi, FP)
    assert np.all(ac > 0)
    np.testing.assert_allclose(rg.rmax_tip_mm(R, fi, ac), rg.rmax_no_tip_mm(R, fi, FP), rtol=1e-9)


def test_isotropic_target():
    h = rg.cusp_height_mm(R, FP)
    assert h == pytest.approx(FP**2 / (8 * R), rel=1e-3)


def test_unreachable_target_is_an_error():
    from ipo.errors import ROUGHNESS_TARGET, IpoError
    with pytest.raises(IpoError, match="roughness target") as info:
        rg.feed_per_tooth_mm(R, FP, 1e-7, np.radians(45))
    assert info.value.code == ROUGHNESS_TARGET
