"""The explorer's "Optics & sensor" view: the current camera's lens and sensor in their units.

A small view over the session's :class:`~camsim_explorer.state.ExplorerState` (it reads
``state.result.camera``, the camera of the last good result, and follows its
f-number and exposure): a table of the optics and EMVA 1288 sensor
parameters in um, e-, e-/s and %, the diffraction-limited MTF at 450, 550
and 650 nm for the current f-number with the pixel's Nyquist frequency, and
the photon-transfer curve (flat-field temporal variance against mean, from
:func:`camsim_core.simulation.electrons.photon_transfer`) for cameras with
an electron-level sensor. No science here: every number comes from the engine.
"""

from __future__ import annotations

import numpy as np
import panel as pn
import param

from camsim_core.camera.physical import PHYSICAL_NAMES, SENSOR_FIELDS
from camsim_core.errors import CamsimError
from camsim_core.optics import cutoff_frequency, diffraction_mtf
from camsim_core.simulation.electrons import photon_transfer, system_gain

from .compat.number_box import FloatInput  # reads any number the browser sends
from .curves import Curve, CurvesPlot, Mark
from .safe_text import md_text
from .shown import now, off_the_loop
from .state import ExplorerState
from .tab import TabView

__all__ = ["PhysicalView", "SensorControls", "parameter_table", "mtf_curves"]

WAVELENGTHS_NM = (450.0, 550.0, 650.0)
_COLOURS = {450.0: "#3050d0", 550.0: "#30a030", 650.0: "#d03030"}


def parameter_table(cam):
    """Markdown table of the camera's optics and sensor parameters with their units."""
    fw = "none" if cam.full_well is None else f"{cam.full_well:,.0f}"
    rows = [
        ("optics", cam.optics, ""),
        ("f-number", f"{cam.f_stop:g}", ""),
        ("focal length", f"{cam.focal_length:g}", "mm"),
        ("defocus", f"{cam.defocus:g}", "dioptres"),
        ("cos^4 relative illumination", "on" if cam.relative_illumination else "off", ""),
        ("pixel pitch", f"{cam.pixel_size[1] * 1e6:.3g}", "um"),
        ("fill factor", f"{cam.fill_factor * 100:.0f}", "%"),
        ("noise model", cam.noise_model, ""),
        ("saturation capacity (full well)", fw, "e-"),
        ("temporal dark noise (read noise)", f"{cam.read_noise:g}", "e- rms"),
        ("dark current", f"{cam.dark_current:g}", "e-/s"),
        ("DSNU", f"{cam.dsnu:g}", "e- rms"),
        ("PRNU", f"{cam.prnu * 100:g}", "%"),
        ("system gain K", f"{system_gain(cam):.4g}", "DN/e-"),
        ("black level", f"{cam.black_level:g}", "DN"),
        ("ADC", "unquantized" if cam.bits is None else f"{cam.bits}", "bits"),
        ("exposure", f"{cam.exposure:g}", "s"),
    ]
    return "| parameter | value | unit |\n| --- | --- | --- |\n" + "\n".join(f"| {a} | {b} | {c} |" for a, b, c in rows)


def mtf_curves(f_number, pitch_m, n=200):
    """{wavelength: (frequencies cycles/mm, MTF)} up to the 450 nm cutoff, and the pixel's Nyquist frequency."""
    f = np.linspace(0.0, float(cutoff_frequency(min(WAVELENGTHS_NM), f_number)), n)
    return {w: (f, diffraction_mtf(f, w, f_number)) for w in WAVELENGTHS_NM}, 1.0 / (2.0 * pitch_m * 1e3)


def _mtf_shown(f_stop, curves, nyquist):
    """``(curves, marks, title)`` of the diffraction-MTF plot (:meth:`CurvesPlot.update`) for the output of
    :func:`mtf_curves` at f-number ``f_stop``: a curve per wavelength, the pixel's Nyquist frequency dashed."""
    return ([Curve(f"{w:g} nm", _COLOURS[w], f, m) for w, (f, m) in curves.items()], [Mark(nyquist)],
            f"Diffraction MTF at f/{f_stop:g} (dashed: Nyquist)")


#: The photon-transfer curves' colours by sensor name (others black).
_PTC_COLOURS = {"R": "#d03030", "G": "#30a030", "B": "#3050d0"}


def _ptc_key(cam):
    """What the photon-transfer curve depends on: the sensor's own parameters (not the noise seed, the scene, ...)."""
    return (cam.noise_model, cam.sensors.name, cam.pixel_size, cam.fill_factor, cam.full_well, cam.read_noise,
            cam.dark_current, cam.dsnu, cam.prnu, cam.electrons_per_dn, cam.analog_gain, cam.bits, cam.black_level,
            cam.exposure, cam.f_stop)


class PhysicalView(TabView):
    """Optics & sensor tab: parameters, diffraction MTF at the current f-number, photon transfer.

    A :class:`~camsim_explorer.tab.TabView` following the state's result: at once while its tab is shown,
    once when it is next shown otherwise. The MTF is
    drawn again only when the f-number or the pixel pitch changed (as new data for the same plot); the
    photon-transfer curve (ten simulated flat fields) is made off the event loop: with a new result in the
    computing thread while the tab is shown, else in a session thread, the note saying so meanwhile.

    Parameters
    ----------
    state : ExplorerState
        The session's state: the camera of its last result is shown.
    when_shown : callable, optional
        The tab's gate (:class:`~camsim_explorer.shown.WhenShown`).

    Examples
    --------
    >>> from camsim_explorer.state import ExplorerState
    >>> view = PhysicalView(ExplorerState(camera="imx174"))
    >>> "system gain K" in view.table.object, "Slope in the linear range" in view.note.object
    (True, True)
    """

    def __init__(self, state, when_shown=now, **params):
        self.table = pn.pane.Markdown("", css_classes=["camsim-physical-table"], width=380)
        self.mtf_curves = CurvesPlot("Diffraction MTF", "Spatial frequency at the sensor (cycles/mm)", "MTF",
                                     frame_width=360, frame_height=220, marks=1)
        # the title fits over the plot in presentation mode's large text ("..., 10 exposures" was cut there)
        self.ptc_curves = CurvesPlot("Photon transfer (EMVA 1288)", "Mean of 10 exposures (DN, black subtracted)",
                                     "Temporal variance (DN²)", frame_width=360, frame_height=220,
                                     legend_location="top_left")
        self.mtf = pn.Column(pn.pane.Bokeh(self.mtf_curves.figure), css_classes=["camsim-mtf"], margin=0)
        self.ptc = pn.pane.Bokeh(self.ptc_curves.figure)
        # shown and hidden as a whole (a camera in digital units has no curve: an empty plot labelled "y" was
        # shown); the Bokeh pane's own ``visible`` would be passed to the figure
        self.ptc_box = pn.Column(self.ptc, css_classes=["camsim-ptc"], visible=False, margin=0)
        self.note = pn.pane.Markdown("", css_classes=["camsim-ptc-note"], width=440)
        self._mtf_key = None  # (f-number, pitch) drawn
        self._ptc_key = None  # the sensor whose curve (or note) is shown
        self._ptc_held, self._ptc_making = None, None  # (key, (ptc, problem)) made off the loop; key being made
        super().__init__(state, when_shown, **params)
        state.preparers.append(self.prepare)
        self._layout = pn.Column(pn.Row(self.table, pn.Column(self.mtf, self.ptc_box, self.note)), name="Optics & sensor")
        self.update()

    def camera(self):
        res = self.state.result
        return None if res is None else res.camera

    def update(self):
        cam = self.camera()
        if cam is None:
            return
        self.table.object = parameter_table(cam)
        key = (float(cam.f_stop), float(cam.pixel_size[1]))
        if key != self._mtf_key:
            self._mtf_key = key
            curves, marks, title = _mtf_shown(key[0], *mtf_curves(*key))
            self.mtf_curves.update(curves, marks, title=title)
        self.update_ptc(cam)

    @staticmethod
    def _ptc_of(cam):
        """``(ptc, problem)``: the engine's photon-transfer curve of ``cam`` over ten exposures, or why not."""
        try:
            return photon_transfer(cam, np.geomspace(cam.exposure / 20, cam.exposure * 2, 10), size=48), ""
        except CamsimError as exc:
            return None, f"Photon transfer unavailable: {md_text(exc)}"

    def prepare(self, res):
        """The photon-transfer curve of a new result's camera, made in the computing thread while the tab is
        shown (``ExplorerState.preparers``) and only when its sensor changed."""
        cam = None if res is None else res.camera
        if cam is None or cam.noise_model != "photon" or not self._tab_shown():
            return
        key = _ptc_key(cam)
        if key != self._ptc_key and (self._ptc_held is None or self._ptc_held[0] != key):
            self._ptc_held = (key, self._ptc_of(cam))

    def update_ptc(self, cam):
        key = _ptc_key(cam)
        if key == self._ptc_key:
            return  # only the sensor's own parameters change the curve (not the noise seed, the scene, ...)
        if cam.noise_model != "photon":
            self._ptc_key = key
            self.ptc_box.visible = False
            self.note.object = ("Photon transfer: this camera's noise is the chapter's Gaussian model in digital units; "
                                "choose a camera with an electron-level sensor (phone-1.4um, imx174).")
            return
        held = self._ptc_held
        if held is not None and held[0] == key:
            self._ptc_key = key
            return self._show_ptc(*held[1])
        if self._ptc_making == key:
            return  # in a thread already

        def made(outcome):  # on the page's next tick: shown if the tab still wants it
            self._ptc_held, self._ptc_making = (key, outcome), None
            self._update_when_shown()

        self._ptc_making = key
        if off_the_loop(lambda: self._ptc_of(cam), made,
                        lambda exc: (None, f"Photon transfer unavailable: {md_text(f'{type(exc).__name__}: {exc}')}")):
            self.ptc_box.visible = False  # the curve shown is another sensor's
            self.note.object = "Simulating the photon-transfer curve (ten flat fields)..."

    def _show_ptc(self, ptc, problem):
        self.ptc_box.visible = ptc is not None
        if ptc is None:
            self.note.object = problem
            return
        self.ptc_curves.update([Curve(name, _PTC_COLOURS.get(name, "black"), ptc["mean"][:, k], ptc["variance"][:, k])
                                for k, name in enumerate(ptc["names"])])
        self.note.object = (f"Slope in the linear range = system gain K = {ptc['gain']:.4g} DN/e-; the variance falls "
                            "where the pixels saturate.")


class SensorControls(pn.viewable.Viewer):
    """The sidebar's Sensor card: the electron-level sensor's fields in their units, for the current camera.

    Each field shows the value in force (the camera sheet's, or the one set
    here); a cleared field returns to the sheet's. A refused value (out of
    range, a full well not above the read noise) gets the state's message and
    the field goes back. For the chapter's cameras, calibrated in digital
    units, the fields are hidden and a note says why. A Panel component
    (``pn.viewable.Viewer``: the fields and the note) following the state's
    camera and sensor (``param.depends``).

    Examples
    --------
    >>> from camsim_explorer.state import ExplorerState
    >>> state = ExplorerState(camera="imx174")
    >>> controls = SensorControls(state, pn.pane.Markdown())
    >>> controls.inputs["read_noise_e"].value
    7.0
    >>> state.camera = "kodak-dcs200-ir"
    >>> controls.inputs["read_noise_e"].visible, "calibrated in digital units" in controls.note.object
    (False, True)
    """

    state = param.ClassSelector(class_=ExplorerState, doc="The session's state: its camera's sensor is shown.")

    #: (label, CSS class) of each field of :data:`SENSOR_FIELDS`
    LABELS = {
        "pixel_pitch_um": ("Pixel pitch (um)", "w-sensor-pitch"),
        "fill_factor_pct": ("Fill factor (%)", "w-sensor-fill"),
        "full_well_e": ("Full well (e-)", "w-sensor-well"),
        "read_noise_e": ("Read noise (e- rms)", "w-sensor-read"),
        "dark_current_e_per_s": ("Dark current (e-/s)", "w-sensor-dark"),
        "dsnu_e": ("DSNU (e- rms)", "w-sensor-dsnu"),
        "prnu_pct": ("PRNU (%)", "w-sensor-prnu"),
    }

    def __init__(self, state, note, **params):
        """``note``: a text holder (``object`` settable) for the line under the fields."""
        self.note = note
        self._busy = False
        self.inputs = {}
        for name, (unit, low, high, what) in SENSOR_FIELDS.items():
            label, css = self.LABELS[name]
            box = FloatInput(label=label, value=None, css_classes=[css], sizing_mode="stretch_width",
                                        description=f"{what}; {low:g} to {high:g} {unit}. Clear it for the camera's own.")
            box.param.watch(lambda e, n=name: self._from_widget(n, e.new), "value")
            self.inputs[name] = box
        super().__init__(state=state, **params)
        self.update()

    @param.depends("state.camera", "state.sensor", watch=True)
    def _on_camera(self):
        self.update()

    def update(self):
        """Show the fields of the camera the parameters describe (disabled for a camera in digital units)."""
        fields = self.state.sensor_fields()
        self._busy = True
        try:
            with pn.io.hold():
                for name, box in self.inputs.items():
                    # a camera in digital units has no such fields: hidden, the note says why (an emptied number
                    # box showed "NaN": Panel sends an empty value to the browser as NaN)
                    box.visible = fields is not None
                    if fields is not None:
                        # six significant digits on screen (a well scaled with the area: 877551, not 877551.0204081632)
                        box.value = self.shown_value(self.state, name, fields)
                self.note.object = (f"Electron-level cameras only ({', '.join(PHYSICAL_NAMES)}): the chapter's cameras "
                                    "are calibrated in digital units" if fields is None else
                                    "The sensor keeps its size: a new pitch changes the pixel count, and the full well "
                                    "follows the pixel's area unless set")
        finally:
            self._busy = False

    @staticmethod
    def shown_value(state, name, fields=None):
        """The value a field's box shows: the field in force, to six significant digits (None: a camera
        calibrated in digital units). ``fields``: ``state.sensor_fields()`` when already at hand."""
        fields = state.sensor_fields() if fields is None else fields
        return None if fields is None else float(f"{fields[name]:.6g}")

    def _from_widget(self, name, value):
        if self._busy:
            return
        kept = self.state.set_sensor_field(name, value)
        if kept != value:  # refused or tidied: the field shows the value in force (after the browser's own change)
            self.state.defer(lambda: self._show(name, kept))

    def _show(self, name, value):
        self._busy = True
        try:
            self.inputs[name].value = value
        finally:
            self._busy = False

    def panel(self):
        """The fields, in order (the sidebar puts them in its card, the note after them)."""
        return list(self.inputs.values())

    def __panel__(self):
        return pn.Column(*self.panel(), self.note, sizing_mode="stretch_width")
