"""The electron-level sensor against EMVA Standard 1288: photon transfer, dark current, saturation, DSNU, PRNU.

Flat fields are simulated at 10 exposure times (EMVA 1288's "variation of
exposure time" method), two frames each plus two dark frames, and analysed
with the standard's formulas written here (Release 4.0, sections 6-8):

* mu_y = mean of the two frames, sigma_y^2 = mean((y_A - y_B)^2) / 2 - (mu_A - mu_B)^2 / 2;
* K: slope through the origin of sigma_y^2 - sigma_y.dark^2 against mu_y - mu_y.dark,
  up to 70 % of the saturation point (the maximum of sigma_y^2);
* sigma_d: sqrt(sigma_y.dark^2 - 1/12) / K extrapolated to zero exposure;
* dark current: slope of mu_y.dark against the exposure time, / K;
* mu_e.sat: eta mu_p at the saturation point;
* DSNU and PRNU from averages of L frames (spatial variance minus sigma_y^2 / L).

Where the ``emva1288`` package (the standard's reference implementation)
installs, its analysis of the same frames is checked too.
"""

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.datasets.sensors import Sensors
from camsim_core.scene import Scene

H_C = 6.62607015e-34 * 299792458.0
LAMBDA, QE, PITCH, F_NUMBER, EPD = 550.0, 0.6, 5.86e-6, 4.0, 4.0
SET = dict(read_noise=7.0, dark_current=40.0, full_well=20000.0, dsnu=3.0, prnu=0.005)
SIZE = 160
OFFSET = 100.0  # DN, the black level: a pedestal so that the dark signal is never clipped at 0


def sensor(**changes):
    sens = Sensors([500.0, 600.0], [[QE, QE]], ("Y",), "Quanta", "mono")
    kw = dict(sensors=sens, pixel_size=(PITCH, PITCH), f_stop=F_NUMBER, electrons_per_dn=EPD, bits=14, height=SIZE,
              width=SIZE, angular_resolution=(57.3, 57.3), noise_model="photon", black_level=OFFSET, pattern_seed=7, **SET)
    kw.update(changes)
    return cs.Camera(**kw)


def photons_per_second(radiance):
    """mu_p / t: photons on one pixel per second, E A lambda / (h c), E = pi L / (4 N^2)."""
    return np.pi * radiance / (4 * F_NUMBER**2) * PITCH**2 * LAMBDA * 1e-9 / H_C


RADIANCE = 0.05
T_FULL = SET["full_well"] / (QE * photons_per_second(RADIANCE))  # exposure that fills the well on average
# ten exposures, denser near saturation, where the variance peaks (EMVA 1288 asks for steps up to saturation)
FRACTIONS = np.array([0.1, 0.2, 0.35, 0.5, 0.65, 0.8, 0.9, 0.98, 1.05, 1.15])


def frame(camera, radiance, t, seed):
    scene = Scene(np.full((SIZE, SIZE, 1), float(radiance)), [LAMBDA], angular_resolution=(57.3, 57.3))
    return cs.simulate(scene, camera, exposure=float(t), seed=int(seed)).data


@pytest.fixture(scope="module")
def series():
    cam = sensor()
    out = []
    for i, t in enumerate(FRACTIONS * T_FULL):
        a, b = frame(cam, RADIANCE, t, 4 * i), frame(cam, RADIANCE, t, 4 * i + 1)
        da, db = frame(cam, 0.0, t, 4 * i + 2), frame(cam, 0.0, t, 4 * i + 3)
        out.append((t, a, b, da, db))
    return out


def mean_var(a, b):
    mu = (a.mean() + b.mean()) / 2
    var = np.mean((a - b) ** 2) / 2 - (a.mean() - b.mean()) ** 2 / 2
    return mu, var


def analyse(series):
    t = np.array([s[0] for s in series])
    mu_y, s2_y = np.array([mean_var(s[1], s[2]) for s in series]).T
    mu_d, s2_d = np.array([mean_var(s[3], s[4]) for s in series]).T
    sat = int(np.argmax(s2_y))
    x, y = mu_y - mu_d, s2_y - s2_d
    lin = x <= 0.7 * x[sat]
    k = float(x[lin] @ y[lin] / (x[lin] @ x[lin]))
    slope, intercept = np.polyfit(t, s2_d, 1)
    sigma_d = np.sqrt(intercept - 1 / 12) / k
    dark = np.polyfit(t, mu_d, 1)[0] / k
    mu_p = photons_per_second(RADIANCE) * t
    responsivity = float(mu_p[lin] @ x[lin] / (mu_p[lin] @ mu_p[lin]))
    eta = responsivity / k
    return dict(K=k, sigma_d=sigma_d, dark_current=dark, mu_e_sat=eta * mu_p[sat], eta=eta, sat=sat)


def test_photon_transfer_recovers_gain_read_noise_dark_current_and_saturation(series):
    r = analyse(series)
    assert r["K"] == pytest.approx(1 / EPD, rel=0.03)
    assert r["sigma_d"] == pytest.approx(SET["read_noise"], rel=0.03)
    assert r["dark_current"] == pytest.approx(SET["dark_current"], rel=0.03)
    assert r["mu_e_sat"] == pytest.approx(SET["full_well"], rel=0.03)
    assert r["eta"] == pytest.approx(QE, rel=0.03)


def spatial(camera, radiance, t, frames=16):
    """EMVA 1288 spatial analysis: the average of L frames, its spatial variance minus sigma_y^2 / L."""
    stack = np.stack([frame(camera, radiance, t, 1000 + i) for i in range(frames)])
    avg = stack.mean(axis=0)
    temporal = stack.var(axis=0, ddof=1).mean()
    return avg.mean(), avg.var(ddof=1) - temporal / frames, stack


def test_dsnu_and_prnu_measured_as_the_standard_does():
    cam = sensor()
    t = 0.5 * T_FULL
    mu_d, s2_d, _ = spatial(cam, 0.0, t)
    mu_y, s2_y, _ = spatial(cam, RADIANCE, t)
    k = 1 / EPD
    assert np.sqrt(s2_d) / k == pytest.approx(SET["dsnu"], rel=0.10)
    assert np.sqrt(s2_y - s2_d) / (mu_y - mu_d) == pytest.approx(SET["prnu"], rel=0.10)


def test_fixed_patterns_are_the_same_in_every_frame_and_temporal_noise_is_not():
    cam = sensor(read_noise=0.0, dark_current=0.0, full_well=None, dsnu=50.0, prnu=0.0)
    a, b = frame(cam, 0.0, 0.01, 1), frame(cam, 0.0, 0.01, 2)
    np.testing.assert_allclose(a, b, atol=0.5 + 1e-9)  # only the DSNU pattern: identical up to rounding
    assert np.corrcoef(a.ravel(), b.ravel())[0, 1] > 0.99
    other = frame(cam.replace(pattern_seed=8), 0.0, 0.01, 1)
    assert abs(np.corrcoef(a.ravel(), other.ravel())[0, 1]) < 0.05
    bright = sensor(read_noise=0.0, dark_current=0.0, full_well=None, dsnu=0.0, prnu=0.0)
    x, y = frame(bright, RADIANCE, 0.5 * T_FULL, 1), frame(bright, RADIANCE, 0.5 * T_FULL, 2)
    assert abs(np.corrcoef(x.ravel(), y.ravel())[0, 1]) < 0.05  # shot noise differs frame to frame


def test_cross_check_with_the_emva1288_reference_implementation(series, monkeypatch):
    emva = pytest.importorskip("emva1288", reason="the emva1288 package does not install here")
    # emva1288 1.0.2 calls np.asfarray, which NumPy 2 removed: give it back for this test only
    monkeypatch.setattr(np, "asfarray", lambda a, dtype=float: np.asarray(a, dtype=dtype), raising=False)
    from emva1288.process.data import Data1288
    from emva1288.process.results import Results1288
    from emva1288.process.routines import get_int_imgs

    temporal = {}
    for i, (t, a, b, da, db) in enumerate(series):
        texp = float(t * 1e9)  # ns, the package's unit
        mu_p = float(photons_per_second(RADIANCE) * t)
        entry = {}
        for photons, imgs in ((0.0, [da, db]), (mu_p, [a, b])):
            d = get_int_imgs([im.astype(np.int64) for im in imgs])
            entry[photons] = {"sum": np.sum(d["sum"]), "pvar": np.sum(d["pvar"]), "dmean": d["dmean"]}
        temporal[texp] = entry
    cam = sensor()
    t = 0.5 * T_FULL
    _, _, dark = spatial(cam, 0.0, t)
    _, _, bright = spatial(cam, RADIANCE, t)
    spatial_data = {float(t * 1e9): {0.0: get_int_imgs(list(dark.astype(np.int64))),
                                     float(photons_per_second(RADIANCE) * t): get_int_imgs(list(bright.astype(np.int64)))}}
    data = Data1288({"temporal": temporal, "spatial": spatial_data, "width": SIZE, "height": SIZE})
    res = Results1288(data.data, pixel_area=(PITCH * 1e6) ** 2, loglevel=40)
    assert res.K == pytest.approx(1 / EPD, rel=0.03)
    assert res.sigma_d == pytest.approx(SET["read_noise"], rel=0.03)
    assert res.u_I_mean == pytest.approx(SET["dark_current"], rel=0.03)
    assert res.u_e_sat == pytest.approx(SET["full_well"], rel=0.03)
    assert res.DSNU1288 == pytest.approx(SET["dsnu"], rel=0.10)
    assert res.PRNU1288 / 100 == pytest.approx(SET["prnu"], rel=0.10)
    assert emva is not None


def test_without_imperfections_the_photon_model_is_the_plain_quantal_model_draw_for_draw():
    """Read noise only, no full well, unit gains: exactly the plain photon model (Poisson, then Gaussian read noise)."""
    cam = sensor(read_noise=2.0, dark_current=0.0, full_well=None, dsnu=0.0, prnu=0.0, electrons_per_dn=1.0, bits=None,
                 black_level=0.0, seed=11)
    scene = Scene(np.random.default_rng(3).uniform(0, 0.02, (SIZE, SIZE, 1)), [LAMBDA], angular_resolution=(57.3, 57.3))
    got = cs.simulate(scene, cam).data
    mean = cs.simulate(scene, cam.replace(noise_model="gaussian", read_noise=0.0)).data
    expected_mean = QE * np.pi * scene.data[:, :, 0] / (4 * F_NUMBER**2) * PITCH**2 * 1.0 * LAMBDA * 1e-9 / H_C
    np.testing.assert_allclose(mean[:, :, 0], expected_mean, rtol=1e-12)
    rng = np.random.default_rng(11)
    plain = rng.poisson(np.clip(mean, 0, None)).astype(float) + rng.normal(0.0, 2.0, size=mean.shape)
    assert np.array_equal(got, plain)


def test_full_well_clips_and_analog_gain_scales():
    cam = sensor(read_noise=0.0, dark_current=0.0, dsnu=0.0, prnu=0.0, bits=None, black_level=0.0)
    over = frame(cam, RADIANCE, 2 * T_FULL, 1)
    assert over.max() == SET["full_well"] / EPD and np.mean(over == SET["full_well"] / EPD) > 0.99
    g1 = frame(cam.replace(full_well=None), RADIANCE, 0.5 * T_FULL, 1)
    g4 = frame(cam.replace(full_well=None, analog_gain=4.0), RADIANCE, 0.5 * T_FULL, 1)
    np.testing.assert_allclose(g4, 4 * g1, rtol=1e-12)


@pytest.mark.parametrize("changes, field", [
    (dict(pixel_size=(-1e-6, 1e-6)), "pixel_size"),
    (dict(fill_factor=0.0), "fill_factor"),
    (dict(fill_factor=1.2), "fill_factor"),
    (dict(full_well=5.0, read_noise=7.0), "full_well"),
    (dict(f_stop=0.4), "f_stop"),
    (dict(dark_current=-1.0), "dark_current"),
    (dict(prnu=float("nan")), "prnu"),
    (dict(analog_gain=0.0), "analog_gain"),
    (dict(noise_model="gaussian"), "noise_model"),  # EMVA fields set, but not the electron-level model
])
def test_bad_sensor_parameters_are_refused_with_the_field_named(changes, field):
    with pytest.raises(cs.ParameterError, match=field):
        sensor(**changes)


# --- physical presets ------------------------------------------------------------------------------


@pytest.mark.parametrize("name, pitch, well, bits", [("phone-1.4um", 1.4, 4300.0, 10), ("imx174", 5.86, 32000.0, 12)])
def test_physical_presets_carry_their_published_parameters_and_sources(cacaphony, name, pitch, well, bits):
    cam = cs.load_camera(name)
    assert cam.pixel_size == (pitch * 1e-6, pitch * 1e-6) and cam.full_well == well and cam.bits == bits
    assert cam.noise_model == "photon" and cam.optics == "diffraction" and cam.sensors.unit == "Quanta"
    assert "source:" in cam.comments and ("EMVA" in cam.comments or "datasheet" in cam.comments)
    # the ADC spans the well: full well x K = 2^bits - 1
    assert cam.full_well / cam.electrons_per_dn == pytest.approx(2**bits - 1)
    # pixels per degree from the pitch and the focal length
    assert cam.angular_resolution[0] == pytest.approx(1 / np.degrees(np.arctan(pitch * 1e-6 / (cam.focal_length * 1e-3))))
    raw = cs.simulate(cacaphony, cam.replace(distance=3.32))
    assert raw.mosaiced and raw.bits == bits and 0 <= raw.data.min() and raw.data.max() <= 2**bits - 1
    assert raw.history[1] == "optics"


def test_phone_preset_read_noise_is_the_datasheets_dynamic_range():
    cam = cs.load_camera("phone-1.4um")
    assert 20 * np.log10(cam.full_well / cam.read_noise) == pytest.approx(68.0, abs=0.1)


def test_a_sensor_sheet_without_its_fields_is_refused(tmp_path):
    from camsim_core.camera import physical_camera

    sheet = tmp_path / "bad.json"
    sheet.write_text('{"pixel_pitch_um": 2.0}')
    with pytest.raises(cs.FileFormatError, match="missing field"):
        physical_camera(str(sheet))
    (tmp_path / "junk.json").write_text("{not json")
    with pytest.raises(cs.FileFormatError, match="JSON"):
        physical_camera(str(tmp_path / "junk.json"))


def test_photon_transfer_curve_of_a_preset_has_the_system_gain_as_its_slope():
    from camsim_core.simulation.electrons import photon_transfer

    cam = cs.load_camera("imx174")
    ptc = photon_transfer(cam, np.linspace(0.001, 0.02, 8), size=96)
    k = cam.analog_gain / cam.electrons_per_dn
    green = list(ptc["names"]).index("G")
    mu, var = ptc["mean"][:, green], ptc["variance"][:, green]
    lin = mu < 0.7 * mu.max()
    slope = np.polyfit(mu[lin], var[lin], 1)[0]
    assert slope == pytest.approx(k, rel=0.05) and ptc["gain"] == pytest.approx(k)
    assert var[-1] < 0.5 * var[lin].max()  # saturated: the temporal variance collapses
    with pytest.raises(cs.ParameterError, match="noise_model"):
        photon_transfer(cs.load_camera("kodak-dcs200-ir"), [0.01, 0.02])
    with pytest.raises(cs.ParameterError, match="exposures"):
        photon_transfer(cam, [0.01, -1])


# --- a design's sensor fields --------------------------------------------------------------------------


def test_a_finer_pitch_on_the_same_sensor_doubles_the_pixels_and_quarters_the_well():
    from camsim_core.camera.physical import sensor_values, with_sensor

    cam = cs.load_camera("imx174")
    fine = with_sensor(cam, pixel_pitch_um=2.93)
    assert (fine.height, fine.width) == (2 * cam.height, 2 * cam.width)  # the sensor keeps its 7.0 x 11.3 mm
    assert fine.height * fine.pixel_size[0] == pytest.approx(cam.height * cam.pixel_size[0])
    # pixels per degree: 1 / degrees(atan(pitch / focal length)), about twice as many
    assert fine.angular_resolution[0] == pytest.approx(1 / np.degrees(np.arctan(2.93e-6 / 12e-3)))
    assert fine.full_well == pytest.approx(8000.0)  # 32 ke- over a quarter of the area
    assert fine.full_well / fine.electrons_per_dn == pytest.approx(4095)  # the 12-bit ADC still spans the well
    # a full well given is kept; the other fields as set, in their units
    set_ = with_sensor(cam, pixel_pitch_um=2.93, full_well_e=12000, prnu_pct=2, fill_factor_pct=80, dark_current_e_per_s=1)
    assert set_.full_well == 12000 and set_.prnu == pytest.approx(0.02) and set_.fill_factor == pytest.approx(0.8)
    assert sensor_values(set_) == {"pixel_pitch_um": 2.93, "fill_factor_pct": 80.0, "full_well_e": 12000.0,
                                   "read_noise_e": 7.0, "dark_current_e_per_s": 1.0, "dsnu_e": 2.0, "prnu_pct": 2.0}


def test_an_8_bit_readout_of_a_12_bit_sensor_drops_low_bits_instead_of_clipping(cacaphony):
    """The explorer's default 8 bits on the 12-bit IMX174: the ADC range keeps spanning the full well
    (before, 8 bits at the sheet's conversion gain clipped at 255 DN = 1,990 e-, a sixteenth of the well)."""
    from camsim_core.review.design import camera_from_params, check_params

    levels = {}
    for bits in (8, 12):
        cam = camera_from_params(check_params({"camera": "imx174", "bits": bits}))
        assert cam.full_well / cam.electrons_per_dn == pytest.approx(2**bits - 1)
        raw = cs.simulate(cacaphony, cam.replace(distance=3.32))
        levels[bits] = float(np.mean(raw.data)) / (2**bits - 1)
    assert 0.1 < levels[12] < 0.9 and levels[8] == pytest.approx(levels[12], rel=0.01)


@pytest.mark.parametrize("camera, text, field, why", [
    ("kodak-dcs200-ir", "full_well_e=8000", "full_well_e", "digital units"),
    ("imx174", "pixel_pitch_um=0.1", "pixel_pitch_um", r"um in \[0.5, 20\]"),
    ("imx174", "prnu_pct=-1", "prnu_pct", r"% in \[0, 100\]"),
    ("imx174", "full_well_e=50, read_noise_e=60", "full_well", "not above the read noise"),
    ("imx174", "full_well=8000", "sensor", "names from pixel_pitch_um"),
    ("imx174", "read_noise_e=abc", "sensor", "expected a number"),
    ("imx174", "read_noise_e=nan", "sensor", "finite"),
])
def test_a_bad_sensor_field_is_refused_naming_it(camera, text, field, why):
    from camsim_core.review.design import camera_from_params, check_params

    with pytest.raises(cs.ParameterError, match=why) as info:
        camera_from_params(check_params({"camera": camera, "sensor": text}))
    assert str(info.value).startswith(field)


def test_sensor_text_reads_back_exactly():
    from camsim_core.camera.physical import SENSOR_FIELDS
    from camsim_core.review.design import parse_sensor, sensor_text

    values = {"prnu_pct": 0.7, "pixel_pitch_um": 2.93, "full_well_e": 8000.0, "dsnu_e": 1 / 3}
    text = sensor_text(values)
    assert text.startswith("pixel_pitch_um=2.93, full_well_e=8000, ")  # SENSOR_FIELDS order, whole numbers plain
    assert parse_sensor(text) == values and list(parse_sensor(text)) == [k for k in SENSOR_FIELDS if k in values]
    assert parse_sensor("") == {} and parse_sensor(" ; ") == {}
