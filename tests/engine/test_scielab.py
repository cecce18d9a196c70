"""S-CIELAB: zero for identical images, plain dE for a uniform shift,
production filtering against an independent direct 2-D convolution, bad input."""

import math

import numpy as np
import pytest
from scipy.signal import convolve2d

import camsim_core
from camsim_core.errors import ParameterError
from camsim_core.metrics import delta_e, filter_opponent, samples_per_degree, scielab
from camsim_core.metrics import display_samples_per_degree

WHITE = np.array([95.047, 100.0, 108.883])

# ---- the numbers, typed in again here (not imported from production) ----
OPP = np.array(
    [
        [0.2787336, 0.7218031, -0.1065520],
        [-0.4487736, 0.2898056, 0.0771569],
        [0.0859513, -0.5899859, 0.5011089],
    ]
)
CHANNELS = [
    [(0.05, 1.00327), (0.225, 0.114416), (7.0, -0.117686)],
    [(0.0685, 0.616725), (0.826, 0.383275)],
    [(0.0920, 0.567885), (0.6451, 0.432115)],
]


def ref_gauss(h, width):
    a = 2 * math.sqrt(math.log(2)) / (h - 1)
    g = [math.exp(-((a * (i - width // 2)) ** 2)) for i in range(width)]
    s = sum(g)
    return np.array([v / s for v in g])


def ref_subsample(k, u):
    """Explicit loops: 'same' convolution with [1..u..1]/u, then every u-th tap out from the centre."""
    tri = [min(i + 1, 2 * u - 1 - i) / u for i in range(2 * u - 1)]
    n, c = len(k), len(k) // 2
    up = np.zeros(n)
    for i in range(n):  # output i, centred: sum_j k[j] tri[i - j + (u - 1)]
        for j in range(n):
            t = i - j + (u - 1)
            if 0 <= t < len(tri):
                up[i] += k[j] * tri[t]
    taps = sorted({c + m * u for m in range(-n, n + 1) if 0 <= c + m * u < n})
    return up[taps]


def ref_kernel_2d(channel, spd):
    """The channel's explicit 2-D kernel: sum over Gaussians of sqrt|w| g(y) * sign(w) sqrt|w| g(x)."""
    u = math.ceil(224 / spd) if spd < 224 else 1
    rate = spd * u
    width = 2 * math.ceil(rate / 2) - 1
    total = 0
    for half, w in CHANNELS[channel]:
        g = ref_gauss(half * rate, width)
        if u > 1:
            g = ref_subsample(g, u)
            g = g / g.sum()  # unit DC gain at every rate (ISETCam's 2-D filters; 1.1.1 leaves it drift)
        total = total + np.outer(math.sqrt(abs(w)) * g, math.copysign(1, w) * math.sqrt(abs(w)) * g)
    return total


def ref_filter(plane, kernel):
    """Mirror (edge included) by min(kernel//2, n//2), zero beyond, direct 2-D convolution, crop."""
    H, W = plane.shape
    c = kernel.shape[0] // 2
    py, px = min(c, H // 2), min(c, W // 2)
    p = np.pad(plane, ((py, py), (px, px)), mode="symmetric")
    p = np.pad(p, ((c - py, c - py), (c - px, c - px)))  # zeros beyond the mirrored margin
    return convolve2d(p, kernel, mode="valid")


# ---------------------------------------------------------------------------
@pytest.mark.parametrize("spd", [250.0, 102.6, 37.0])
@pytest.mark.parametrize("shape", [(70, 90), (23, 31), (5, 160)])
def test_filtering_matches_direct_2d_convolution(spd, shape):
    """Production (FFT of the summed kernel) == direct 2-D convolution, above and below 224 samples/deg;
    (23, 31) is smaller than every kernel here, exercising the half-image mirror and the zeros beyond;
    (5, 160) a strip only 5 rows high."""
    if spd == 250.0 and shape == (70, 90):
        shape = (40, 45)  # keep the direct convolution with a 249-tap kernel quick
    rng = np.random.default_rng(1)
    opp = rng.normal(size=shape + (3,))
    out = filter_opponent(opp, spd)
    for ch in range(3):
        ref = ref_filter(opp[..., ch], ref_kernel_2d(ch, spd))
        np.testing.assert_allclose(out[..., ch], ref, rtol=0, atol=1e-9)


def test_upsampled_kernel_width_and_taps():
    """At 102.6 samples/deg: u = 3, kernels built at 307.8/deg are 307 wide, keep 103 taps."""
    k = ref_kernel_2d(0, 102.6)
    out = filter_opponent(np.zeros((120, 120, 3)) + [1, 0, 0], 102.6)
    assert k.shape == (103, 103)
    # unit DC gain of the luminance filter at this rate: a uniform field stays uniform
    np.testing.assert_allclose(out[..., 0], 1.0, atol=1e-12)


def test_identical_images_give_zero():
    rng = np.random.default_rng(2)
    xyz = rng.uniform(5, 90, size=(64, 80, 3))
    d = scielab(xyz, xyz.copy(), 102.6, WHITE)
    assert d.shape == (64, 80)
    assert np.max(np.abs(d)) < 1e-9


@pytest.mark.parametrize("spd", [1.5, 2.0, 4.0, 8.0, 16.0, 37.0, 102.6, 230.0])
@pytest.mark.parametrize("method", ["CIE 1976", "CIE 2000"])
def test_uniform_shift_equals_plain_delta_e(spd, method):
    """Images larger than the kernel: every channel filter has unit DC gain, so S-CIELAB == CIELAB."""
    n = 2 * math.ceil(spd / 2) + 8
    a = np.ones((n, n + 5, 3)) * [30.0, 35.0, 20.0]
    b = np.ones((n, n + 5, 3)) * [34.0, 31.0, 26.0]
    s = scielab(a, b, spd, WHITE, method=method)
    plain = delta_e(a, b, WHITE, method=method)
    assert plain.min() > 3  # a real difference, not a trivial zero
    np.testing.assert_allclose(s, plain, rtol=1e-9)


def test_blur_lowers_fine_pattern_difference():
    """A fine red-green grating (2 px period at 102.6/deg, ~51 c/deg) against its mean: CIELAB sees a
    large difference per pixel; the eye's filter (S-CIELAB) makes it nearly invisible."""
    n = 120
    a = np.ones((n, n, 3)) * [30.0, 30.0, 30.0]
    b = a.copy()
    b[:, ::2] += [4.0, -2.0, 0.0]
    b[:, 1::2] -= [4.0, -2.0, 0.0]
    s = scielab(a, b, 102.6, WHITE)
    plain = delta_e(a, b, WHITE)
    assert plain.mean() > 5 * s[20:-20, 20:-20].mean()


# ---- samples per degree ----------------------------------------------------
def test_samples_per_degree_is_the_camera_angular_resolution():
    cam = camsim_core.load_camera("kodak-dcs200-ir")
    assert samples_per_degree(cam) == pytest.approx(102.6)
    assert samples_per_degree((100.0, 121.0)) == pytest.approx(110.0)


def test_display_samples_per_degree_small_angle():
    # 0.25 mm pixels at 0.5 m: pitch/distance = 5e-4 rad per pixel -> (pi / 180) / 5e-4 = 34.9 per degree
    s = display_samples_per_degree(0.25e-3, 0.5)
    assert s == pytest.approx(math.pi / 180 / 5e-4, rel=1e-6)


# ---- bad input -------------------------------------------------------------
def test_different_shapes_error():
    with pytest.raises(ParameterError, match="same shape"):
        scielab(np.ones((10, 12, 3)), np.ones((10, 13, 3)), 102.6, WHITE)


@pytest.mark.parametrize("spd", [0, -5.0, float("nan"), float("inf"), "many"])
def test_non_positive_samples_per_degree_error(spd):
    with pytest.raises(ParameterError, match="samples_per_degree"):
        scielab(np.ones((10, 12, 3)), np.ones((10, 12, 3)), spd, WHITE)


@pytest.mark.parametrize("white", [[95.0, 0.0, 108.0], [0.0, 100.0, 100.0], [95.0, 100.0], [95.0, -1.0, 100.0]])
def test_bad_white_error(white):
    with pytest.raises(ParameterError, match="white"):
        scielab(np.ones((10, 12, 3)), np.ones((10, 12, 3)), 102.6, white)


def test_unknown_method_error():
    with pytest.raises(ParameterError, match="method"):
        scielab(np.ones((10, 12, 3)), np.ones((10, 12, 3)), 102.6, WHITE, method="CIE 1994 plus")


def test_errors_are_value_errors():
    with pytest.raises(ValueError, match="positive"):
        scielab(np.ones((10, 12, 3)), np.ones((10, 12, 3)), 0, WHITE)


# ---------------------------------------------------------------------------
# bands of rows, rendered images in, bounded memory
@pytest.mark.parametrize("band_rows", [7, 16, 40])
def test_filtering_by_many_bands_matches_direct_2d_convolution(monkeypatch, band_rows):
    """Bands much shorter than the kernel (top and bottom bands reaching into the mirror and the zeros,
    a last band shorter than the others) give the direct 2-D convolution, as one band does."""
    from camsim_core.metrics import s_cielab

    monkeypatch.setattr(s_cielab, "BAND_ROWS", band_rows)
    rng = np.random.default_rng(4)
    opp = rng.normal(size=(61, 47, 3))
    out = filter_opponent(opp, 37.0)
    for ch in range(3):
        ref = ref_filter(opp[..., ch], ref_kernel_2d(ch, 37.0))
        np.testing.assert_allclose(out[..., ch], ref, rtol=0, atol=1e-9)


def test_wide_images_are_filtered_in_shorter_bands():
    """Over BAND_PIXELS / BAND_ROWS pixels wide, a band has fewer rows (not under 128); an image of several
    bands gets an even number of equal ones (two cores, the same work each)."""
    from camsim_core.metrics import s_cielab

    assert s_cielab._band_rows((512, 300)) == 512  # one band
    assert s_cielab._band_rows((2000, 300)) == 500  # 4 bands of at most 512 rows
    assert s_cielab._band_rows((1012, 1317)) == 253  # 398 rows at most: 3 bands, made 4
    assert s_cielab._band_rows((3000, 4000)) == 125  # (1 << 19) // 4000 == 131 rows at most: 23 bands, made 24
    assert s_cielab._band_rows((100, 100_000)) == 100  # 128 rows at most: one band
    assert s_cielab._band_rows((1000, 100_000)) == 125  # 8 bands of 125 rows


@pytest.fixture(scope="module")
def rendered_pair():
    """A rendered camera image and its ideal image (the default scene, DCS-200), float32 and float64."""
    cs = camsim_core
    mon = cs.load_monitor("simtoolbox-test")
    scene = cs.load_scene("cacaphony290")
    cam = cs.load_camera("kodak-dcs200-ir").replace(noise_sigma=2.0, seed=3)
    at = dict(distance=3.32, exposure=0.1)  # the chapter's setting: at the calibration's 1 s every raw value clips
    ren = cs.render(cs.demosaic(cs.simulate(scene, cam, **at), "bilinear"), mon)
    ideal = cs.ideal_image(scene, cam, mon, **at)
    return mon, cam, ren, ideal


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_rendered_images_with_their_monitor_give_the_numbers_of_to_xyz(rendered_pair, dtype):
    """delta_e / scielab(rendered, ideal, monitor=) == the same metric of to_xyz of each, exactly."""
    cs = camsim_core
    mon, cam, ren, ideal = rendered_pair
    ren, ideal = ren.replace(data=ren.data.astype(dtype)), ideal.replace(data=ideal.data.astype(dtype))
    white = cs.rendering.white_xyz(mon)
    spd = samples_per_degree(cam)
    xyz, ixyz = cs.to_xyz(ren, mon), cs.to_xyz(ideal, mon)
    np.testing.assert_array_equal(delta_e(ren, ideal, white, monitor=mon), delta_e(xyz, ixyz, white))
    np.testing.assert_array_equal(scielab(ren, ideal, spd, white, monitor=mon), scielab(xyz, ixyz, spd, white))
    assert scielab(ren, ideal, spd, white, monitor="simtoolbox-test").mean() > 0.5  # noise: a real difference


def test_rendered_images_without_a_monitor_are_refused(rendered_pair):
    mon, cam, ren, ideal = rendered_pair
    with pytest.raises(ParameterError, match="xyz1.*rendered image.*monitor="):
        scielab(ren, ideal, 102.6, WHITE)
    with pytest.raises(ParameterError, match="xyz2.*rendered image"):
        delta_e(np.ones((3, 4, 3)), ideal, WHITE)
    raw = camsim_core.simulate(camsim_core.load_scene("cacaphony290"), camsim_core.load_camera("kodak-dcs200-ir"))
    with pytest.raises(ParameterError, match="xyz1.*rendered monitor image"):
        delta_e(raw, ideal, WHITE, monitor=mon)


def test_scielab_of_rendered_images_holds_no_full_size_temporary(rendered_pair):
    """S-CIELAB of rendered float32 images 2400 and 4800 rows high (1200 wide), traced by tracemalloc (numpy
    reports its arrays to it): the memory beyond the (H, W) output is the same for both (bands of 400 rows),
    where one full-size XYZ, opponent or filtered image would add 2 x 2400 x 1200 x 12 bytes (66 MiB)."""
    import tracemalloc

    mon, cam, ren, ideal = rendered_pair
    white = camsim_core.rendering.white_xyz(mon)

    def transient(h):
        a = ren.replace(data=np.resize(ren.data.astype(np.float32), (h, 1200, 3)))
        b = ideal.replace(data=np.resize(ideal.data.astype(np.float32), (h, 1200, 3)))
        tracemalloc.start()
        try:
            out = scielab(a, b, 102.6, white, monitor=mon)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert out.shape == (h, 1200) and np.all(np.isfinite(out))
        return peak - out.nbytes

    from camsim_core.metrics import s_cielab

    assert s_cielab._band_rows((2400, 1200)) == s_cielab._band_rows((4800, 1200)) == 400  # 6 and 12 bands
    transient(2400)  # kernel spectra, FFT plans, tables: made once, not the call's
    small, large = transient(2400), transient(4800)
    assert large - small < 8 * 2**20, f"{small / 2**20:.0f} MiB at 2400 rows, {large / 2**20:.0f} MiB at 4800"


def test_xyz_filtering_is_opponent_filtering_between_the_two_matrices():
    """scielab_filter = XYZ -> opponent (XYZ_TO_OPPONENT), filter_opponent, back (OPPONENT_TO_XYZ): the
    conversions done pixel by pixel in the filter's own pass give the products numpy gives."""
    from camsim_core.metrics.s_cielab import OPPONENT_TO_XYZ, XYZ_TO_OPPONENT, scielab_filter

    rng = np.random.default_rng(7)
    xyz = rng.uniform(0.0, 90.0, size=(37, 53, 3))
    expected = filter_opponent(xyz @ XYZ_TO_OPPONENT.T, 61.0) @ OPPONENT_TO_XYZ.T
    np.testing.assert_allclose(scielab_filter(xyz, 61.0), expected, rtol=0, atol=1e-10)


@pytest.mark.filterwarnings("ignore:invalid value encountered")
def test_opponent_channels_are_filtered_apart():
    """filter_opponent takes its channels as they are: a non-finite value in one channel (whose transform
    it fills with NaN) leaves the other two channels' numbers untouched (no 0 * inf mixes them)."""
    rng = np.random.default_rng(8)
    opp = rng.normal(size=(30, 40, 3))
    clean = filter_opponent(opp, 37.0)
    opp[10, 12, 0] = np.inf
    out = filter_opponent(opp, 37.0)
    assert np.isnan(out[..., 0]).all()
    np.testing.assert_array_equal(out[..., 1:], clean[..., 1:])


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("shape", [(600, 310), (41, 29)])
def test_filtered_lab_is_the_lab_of_the_filtered_image_bit_for_bit(dtype, shape):
    """filtered_lab goes from each band's filtered channels straight to L*a*b*; its numbers are those of
    the two public steps done apart (scielab_filter, then xyz_to_lab), to the last bit, in either dtype,
    over several bands (600 rows) and where the kernel reaches past the mirror (41 x 29)."""
    from camsim_core.metrics import filtered_lab, scielab_filter, xyz_to_lab

    rng = np.random.default_rng(11)
    xyz = rng.uniform(0.5, 90.0, size=shape + (3,)).astype(dtype)
    xyz[3, 4] = 0.0  # L* on the linear segment of the CIE function
    lab = filtered_lab(xyz, 102.6, WHITE)
    assert lab.dtype == dtype
    np.testing.assert_array_equal(lab, xyz_to_lab(scielab_filter(xyz, 102.6), WHITE))


@pytest.mark.parametrize("method", ["CIE 1976", "CIE 2000"])
def test_scielab_is_the_difference_of_the_two_filtered_labs(method):
    """scielab (two images band by band) equals delta_e_lab of the two filtered_lab images: the band
    buffers of one image never leak into the other's, also for a float32 image against a float64 one."""
    from camsim_core.metrics import delta_e_lab, filtered_lab

    rng = np.random.default_rng(12)
    a = rng.uniform(0.5, 90.0, size=(530, 200, 3)).astype(np.float32)
    b = rng.uniform(0.5, 90.0, size=(530, 200, 3))
    expected = delta_e_lab(filtered_lab(a, 80.0, WHITE), filtered_lab(b, 80.0, WHITE), method)
    np.testing.assert_array_equal(scielab(a, b, 80.0, WHITE, method=method), expected)


def test_a_band_lets_its_transforms_go_when_the_next_is_asked_for():
    """A band of the filter is valid until the next is asked for; then its three transforms are let go even
    though the caller's loop variable still holds it (at 12 MP that was 12 MiB more per image at the peak)."""
    from camsim_core.metrics import s_cielab

    xyz = np.random.default_rng(13).uniform(1.0, 90.0, size=(1100, 300, 3)).astype(np.float32)
    bands = s_cielab._filtered_bands(xyz, 102.6)
    first = next(bands)[2]
    assert len(first.planes) == 3 and first.rows == s_cielab._band_rows(xyz.shape[:2])
    second = next(bands)[2]
    assert first.planes is None and len(second.planes) == 3
