"""CIELAB differences and the registered block comparison."""

import colour
import numpy as np
import pytest

from camsim_core.errors import ParameterError
from camsim_core.metrics import block_average, block_compare, delta_e, register, xyz_to_lab

WHITE = np.array([95.047, 100.0, 108.883])  # D65, Y = 100

# Sharma, Wu & Dalal (2005), Table 1: CIEDE2000 test pairs (L*, a*, b*) and their published dE00.
# Pairs 10 and 14 sit exactly on the 180 degree hue discontinuity the paper is testing, where a
# round trip through XYZ (1e-13) may fall on either side; they are left out.
SHARMA = [
    ((50.0000, 2.6772, -79.7751), (50.0000, 0.0000, -82.7485), 2.0425),
    ((50.0000, 3.1571, -77.2803), (50.0000, 0.0000, -82.7485), 2.8615),
    ((50.0000, 2.8361, -74.0200), (50.0000, 0.0000, -82.7485), 3.4412),
    ((50.0000, -1.3802, -84.2814), (50.0000, 0.0000, -82.7485), 1.0000),
    ((50.0000, -1.1848, -84.8006), (50.0000, 0.0000, -82.7485), 1.0000),
    ((50.0000, -0.9009, -85.5211), (50.0000, 0.0000, -82.7485), 1.0000),
    ((50.0000, 0.0000, 0.0000), (50.0000, -1.0000, 2.0000), 2.3669),
    ((50.0000, -1.0000, 2.0000), (50.0000, 0.0000, 0.0000), 2.3669),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0009), 7.1792),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0011), 7.2195),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0012), 7.2195),
    ((50.0000, -0.0010, 2.4900), (50.0000, 0.0009, -2.4900), 4.8045),
    ((50.0000, -0.0010, 2.4900), (50.0000, 0.0011, -2.4900), 4.7461),
    ((50.0000, 2.5000, 0.0000), (50.0000, 0.0000, -2.5000), 4.3065),
    ((50.0000, 2.5000, 0.0000), (73.0000, 25.0000, -18.0000), 27.1492),
    ((50.0000, 2.5000, 0.0000), (61.0000, -5.0000, 29.0000), 22.8977),
    ((50.0000, 2.5000, 0.0000), (56.0000, -27.0000, -3.0000), 31.9030),
    ((50.0000, 2.5000, 0.0000), (58.0000, 24.0000, 15.0000), 19.4535),
    ((50.0000, 2.5000, 0.0000), (50.0000, 3.1736, 0.5854), 1.0000),
    ((50.0000, 2.5000, 0.0000), (50.0000, 3.2972, 0.0000), 1.0000),
    ((50.0000, 2.5000, 0.0000), (50.0000, 1.8634, 0.5757), 1.0000),
    ((50.0000, 2.5000, 0.0000), (50.0000, 3.2592, 0.3350), 1.0000),
    ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644),
    ((63.0109, -31.0961, -5.8663), (62.8187, -29.7946, -4.0864), 1.2630),
    ((61.2901, 3.7196, -5.3901), (61.4292, 2.2480, -4.9620), 1.8731),
    ((35.0831, -44.1164, 3.7933), (35.0232, -40.0716, 1.5901), 1.8645),
    ((22.7233, 20.0904, -46.6940), (23.0331, 14.9730, -42.5619), 2.0373),
    ((36.4612, 47.8580, 18.3852), (36.2715, 50.5065, 21.2231), 1.4146),
    ((90.8027, -2.0831, 1.4410), (91.1528, -1.6435, 0.0447), 1.4441),
    ((90.9257, -0.5406, -0.9208), (88.6381, -0.8985, -0.7239), 1.5381),
    ((6.7747, -0.2908, -2.4247), (5.8714, -0.0985, -2.2286), 0.6377),
    ((2.0776, 0.0795, -1.1350), (0.9033, -0.0636, -0.5514), 0.9082),
]


def lab_to_xyz(lab, white):
    """Textbook inverse of CIE 1976 L*a*b* (CIE 15:2004), written here as an independent reference."""
    lab = np.asarray(lab, float)
    fy = (lab[..., 0] + 16) / 116
    fx = fy + lab[..., 1] / 500
    fz = fy - lab[..., 2] / 200
    eps = 6 / 29

    def finv(f):
        return np.where(f > eps, f**3, 3 * eps**2 * (f - 4 / 29))

    return np.stack([finv(fx), finv(fy), finv(fz)], axis=-1) * white


def test_ciede2000_matches_sharma_2005_published_pairs():
    lab1 = np.array([p[0] for p in SHARMA])
    lab2 = np.array([p[1] for p in SHARMA])
    expected = np.array([p[2] for p in SHARMA])
    d = delta_e(lab_to_xyz(lab1, WHITE), lab_to_xyz(lab2, WHITE), WHITE, method="CIE 2000")
    np.testing.assert_allclose(d, expected, atol=1e-4)


def test_cie1976_is_euclidean_distance_in_lab():
    lab1 = np.array([p[0] for p in SHARMA])
    lab2 = np.array([p[1] for p in SHARMA])
    d = delta_e(lab_to_xyz(lab1, WHITE), lab_to_xyz(lab2, WHITE), WHITE)
    np.testing.assert_allclose(d, np.linalg.norm(lab1 - lab2, axis=-1), atol=1e-9)


def test_delta_e_against_colour_science_with_relative_white():
    """colour-science with Y normalized to 1 and the white as xy (its own convention) gives the same map,
    so delta_e is independent of the absolute unit of XYZ."""
    rng = np.random.default_rng(3)
    xyz1 = rng.uniform(1, 90, size=(6, 7, 3))
    xyz2 = rng.uniform(1, 90, size=(6, 7, 3))
    white = np.array([98.0, 100.0, 80.0])  # a warm white, not D65
    xy = white[:2] / white.sum()
    for method in ("CIE 1976", "CIE 2000"):
        ref = colour.delta_E(
            colour.XYZ_to_Lab(xyz1 / 100.0, xy), colour.XYZ_to_Lab(xyz2 / 100.0, xy), method=method
        )
        got = delta_e(xyz1 * 3.5, xyz2 * 3.5, white * 3.5, method=method)
        assert got.shape == (6, 7)
        np.testing.assert_allclose(got, ref, rtol=1e-10)


def test_white_maps_to_L_100():
    lab = xyz_to_lab(WHITE * 2, WHITE * 2)
    np.testing.assert_allclose(lab, [100, 0, 0], atol=1e-9)


def test_delta_e_bad_input():
    a = np.ones((4, 5, 3))
    with pytest.raises(ParameterError, match="same shape"):
        delta_e(a, np.ones((5, 4, 3)), WHITE)
    with pytest.raises(ParameterError, match="white"):
        delta_e(a, a, [95.0, 0.0, 100.0])
    with pytest.raises(ParameterError, match=r"\(\.\.\., 3\)"):
        delta_e(np.ones((4, 5)), np.ones((4, 5)), WHITE)
    with pytest.raises(ParameterError, match="NaN"):
        delta_e(a * np.nan, a, WHITE)
    with pytest.raises(ParameterError, match="method"):
        delta_e(a, a, WHITE, method="CMC")


# ---- block averages and registration ---------------------------------------
def textured_xyz(shape, seed=0):
    """A smooth random colour texture (XYZ, Y in ~10-90) with structure at several scales."""
    from scipy.ndimage import gaussian_filter, zoom

    rng = np.random.default_rng(seed)
    small = rng.uniform(10, 90, size=(shape[0] // 8 + 2, shape[1] // 8 + 2, 3))
    big = zoom(small, (8, 8, 1), order=3)[: shape[0], : shape[1]]
    big += gaussian_filter(rng.normal(0, 8, size=shape + (3,)), (1.5, 1.5, 0))
    return np.clip(big, 1, None)


def test_block_average_exact_means():
    img = np.arange(6 * 9, dtype=float).reshape(6, 9)
    m = block_average(img, 3)
    assert m.shape == (2, 3)
    assert m[0, 0] == pytest.approx(np.mean(img[:3, :3]))
    assert m[1, 2] == pytest.approx(np.mean(img[3:6, 6:9]))


def test_register_finds_known_crop_offset():
    big = textured_xyz((160, 200))
    crop = big[37:37 + 100, 51:51 + 120]
    reg = register(crop, big, scales=None)
    assert reg.scale == 1.0
    np.testing.assert_allclose(reg.shift, (37, 51), atol=0.15)
    assert reg.score > 0.99


def test_register_finds_known_scale():
    """The moving image is the fixed one magnified by 1.25 (bilinear): the search recovers the scale."""
    from scipy.ndimage import map_coordinates

    fixed = textured_xyz((120, 150), seed=4)
    s = 0.8  # moving pixel (r, c) shows fixed point (s r + 5, s c + 7)
    rr, cc = np.meshgrid(s * np.arange(130) + 5, s * np.arange(160) + 7, indexing="ij")
    moving = np.stack([map_coordinates(fixed[..., k], [rr, cc], order=3) for k in range(3)], axis=-1)
    reg = register(fixed[20:100, 20:120], moving, scales=(0.7, 1.4))
    # fixed (r + 20, c + 20) = moving((r + 20 - 5) / s, (c + 20 - 7) / s): scale 1/s = 1.25, shift (18.75, 16.25)
    assert reg.scale == pytest.approx(1.25, rel=0.01)
    np.testing.assert_allclose(reg.shift, (18.75, 16.25), atol=1.0)


def test_block_compare_identical_crop_is_zero_and_detects_a_shift():
    big = textured_xyz((160, 200), seed=1)
    crop = big[30:130, 40:160]
    same = block_compare(crop, big, 20, WHITE, scales=None)
    assert same.delta_e.shape == (5, 6)
    assert same.median < 0.05
    # a colour cast on the moving image shows up with its CIELAB size in every block
    cast = big * [1.0, 1.0, 1.2]
    res = block_compare(crop, cast, 20, WHITE, scales=None)
    plain = delta_e(same.means1, same.means1 * [1.0, 1.0, 1.2], WHITE)
    np.testing.assert_allclose(res.delta_e, plain, rtol=0.02)
    counts, edges = res.histogram(bins=5)
    assert counts.sum() == 30


def test_block_compare_bad_input():
    a = textured_xyz((60, 60))
    with pytest.raises(ParameterError, match="block"):
        block_compare(a, a, 0, WHITE, register_images=False)
    with pytest.raises(ParameterError, match="block"):
        block_compare(a, a, 61, WHITE, register_images=False)
    with pytest.raises(ParameterError, match="same shape"):
        block_compare(a, a[:50], 10, WHITE, register_images=False)
    with pytest.raises(ParameterError, match="white"):
        block_compare(a, a, 10, [1.0, 0.0, 1.0], register_images=False)


def test_a_pair_whose_second_image_is_checked_elsewhere_still_checks_the_first_and_the_shapes():
    """check_pair(check_second=False), as the explorer's pipeline calls it (the ideal image is checked once,
    where its L*a*b* is made): the first image's values and both shapes are still checked, by name."""
    from camsim_core.metrics.cielab import check_pair

    good, bad = np.ones((4, 5, 3)), np.ones((4, 5, 3))
    bad[1, 2, 0] = np.nan
    a, b = check_pair(good, bad, check_second=False)
    assert b is bad or np.shares_memory(b, bad)
    with pytest.raises(ParameterError, match="xyz2"):
        check_pair(good, bad)
    with pytest.raises(ParameterError, match="xyz1.*NaN"):
        check_pair(bad, good, check_second=False)
    with pytest.raises(ParameterError, match="xyz2.*same shape"):
        check_pair(good, np.ones((4, 6, 3)), check_second=False)
