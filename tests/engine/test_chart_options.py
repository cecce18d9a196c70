"""Chart options in a scene name ("slanted-edge:angle=10"): every one parsed and checked, every bad one a
ParameterError naming it (never a TypeError from inside numpy), nothing allocated for a chart too large."""

import tracemalloc

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.datasets.sensors import cie1931_xyz
from camsim_core.errors import CamsimError, ParameterError
from camsim_core.scene import munsell_scene, slanted_edge_scene
from camsim_core.scene.charts import chart

#: The options of each chart that take numbers (written out here, not read from the charts).
NUMERIC = {
    "slanted-edge": ["size", "angle", "contrast", "light", "luminance", "distance", "angular_resolution", "wavelengths"],
    "zone-plate": ["size", "max_frequency", "mean", "amplitude", "luminance", "distance", "angular_resolution",
                   "wavelengths"],
    "uniform": ["size", "luminance", "distance", "angular_resolution", "wavelengths"],
    "munsell": ["rows", "cols", "patch_size", "border", "chips", "luminance", "distance", "angular_resolution",
                "wavelengths"],
    "macbeth": ["patch_size", "border", "luminance", "distance", "angular_resolution"],
}
BAD = ["abc", "nan", "inf", "-inf", "-1", "1e400", "9" * 10_000, "\uff15", "\u0661\u0662", "1e5x", "True", "[1 2]"]
CASES = [(c, o, v) for c, opts in NUMERIC.items() for o in opts for v in BAD]


def _refused(text):
    with pytest.raises(ParameterError) as info:
        cs.load_scene(text)
    assert isinstance(info.value, CamsimError)
    return info.value


@pytest.mark.parametrize("name, option, value", CASES, ids=[f"{c}-{o}-{v[:8]}" for c, o, v in CASES])
def test_a_bad_numeric_option_is_a_parameter_error_naming_it(name, option, value):
    err = _refused(f"{name}:{option}={value}")
    assert err.name == option, str(err)
    assert len(str(err)) < 400  # a 10,000-character value is not echoed back whole


@pytest.mark.parametrize("name", list(NUMERIC))
def test_an_empty_value_or_a_duplicated_key_is_refused_by_name(name):
    option = NUMERIC[name][1]
    err = _refused(f"{name}:{option}=")
    assert err.name == option and "no value" in str(err)
    err = _refused(f"{name}:{option}=1,{option}=2")
    assert err.name == option and "more than once" in str(err)


@pytest.mark.parametrize("text, named", [
    ("slanted-edge:angel=10", "angel"), ("zone-plate:\u00e1ngle=5", "\u00e1ngle"), ("uniform:size=16,bogus=1", "bogus"),
    ("munsell:k" + "k" * 9_999 + "=1", "characters")])
def test_an_unknown_option_is_refused_naming_it(text, named):
    err = _refused(text)
    assert named in str(err) and len(str(err)) < 400


@pytest.mark.parametrize("options, option", [
    ({"angle": "abc"}, "angle"), ({"angle": None}, "angle"), ({"angle": [5, 6]}, "angle"), ({"angle": True}, "angle"),
    ({"contrast": float("nan")}, "contrast"), ({"light": 10**400}, "light"), ({"luminance": 10**400}, "luminance"),
    ({"size": "axb"}, "size"), ({"size": (8, 8, 8)}, "size"), ({"size": 12.5}, "size"), ({"distance": "far"}, "distance"),
    ({"angular_resolution": (1, 2, 3)}, "angular_resolution"), ({"wavelengths": [500, 400]}, "wavelengths"),
    ({"illuminant": "x" * 10_000}, "illuminant")])
def test_bad_options_given_as_python_values_are_refused_by_name(options, option):
    with pytest.raises(ParameterError) as info:
        chart("slanted-edge", **options)
    assert info.value.name == option
    with pytest.raises(ParameterError) as info:
        slanted_edge_scene(**{"size": 16, **options})
    assert info.value.name == option


@pytest.mark.parametrize("text", ["uniform:size=" + "1" * 5_001, "uniform:size=1000000", "slanted-edge:size=65536x65536",
                                  "munsell:rows=1000000000", "munsell:patch_size=100000000,cols=1,rows=1"])
def test_a_huge_chart_is_refused_before_anything_is_allocated(text):
    chart("munsell:rows=1,cols=1,patch_size=1,border=0")  # the data and modules a chart needs, loaded before measuring
    tracemalloc.start()
    try:
        with pytest.raises(ParameterError):
            cs.load_scene(text)
        with pytest.raises(ParameterError, match="more than"):
            chart("uniform", size=10**5000)  # a Python int beyond any float
        with pytest.raises(ParameterError, match="more than"):
            munsell_scene(rows=10**9)  # the generator itself, not only chart(), refuses before allocating
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2e6  # bytes: nothing of the chart's size was made


def test_valid_options_still_make_their_charts():
    s = cs.load_scene("slanted-edge: angle = -10 , contrast=2.5,light=0.5,size=32x48,luminance=50,distance=2,"
                      "angular_resolution=100,illuminant=A")
    assert s.shape == (32, 48, 31) and s.distance == 2.0 and s.angular_resolution == (100.0, 100.0)
    assert s.illuminant.name == "CIE A" and "-10 deg, contrast 2.5:1" in s.comments
    refl = s.data[:, :, 15] / s.illuminant.values[15]
    assert refl.max() == pytest.approx(0.5) and refl.min() == pytest.approx(0.2)  # light 0.5, dark 0.5 / 2.5
    z = cs.load_scene("zone-plate:max_frequency=0.25,mean=0.4,amplitude=0.3,size=16")
    zr = z.data[:, :, 10] / z.illuminant.values[10]
    assert z.shape == (16, 16, 31) and zr.max() <= 0.7 + 1e-12 and zr.min() >= 0.1 - 1e-12
    u = cs.load_scene("uniform:luminance=12.5,size=8,wavelengths=550")
    assert u.shape == (8, 8, 1)
    assert 683.0 * cie1931_xyz().on(u.wavelengths)[1] @ u.data[0, 0] == pytest.approx(12.5, rel=1e-6)
    m = cs.load_scene("munsell:rows=2,cols=3,patch_size=5,border=2")
    assert m.shape == (2 + 2 * 7, 2 + 3 * 7, 31)
    one = cs.load_scene("munsell:rows=1,cols=1,chips=5,patch_size=4,border=0")
    assert one.shape == (4, 4, 31)
    assert chart("slanted-edge", size=np.int64(16), angle=np.float32(7.5)).shape == (16, 16, 31)
    assert "12.5 cd/m^2" in chart("uniform", size="8x8", luminance="12.5").comments  # text as Python values too
