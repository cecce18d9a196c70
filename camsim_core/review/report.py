"""A self-contained HTML report of camera designs compared on one scene (``camsim report``).

Everything is inside one file: images as base64 PNG ``data:`` URIs, plots
drawn with matplotlib (Agg) into PNGs, no script, style sheet or font from
outside, so the report opens offline in any browser. It holds, for each
design: the rendered image and its dE map (all maps on one colour scale),
the mean, median and 95th percentile of CIELAB and S-CIELAB dE against the
ideal image; the parameters that differ between designs and every
parameter; the overlaid dE histograms; the A/B difference of the first two
designs; the sweep plot and its points when a sweep was run; the camsim
version and the scene. A ``<script type="application/json">`` block repeats
the numbers for machines.

No GUI imports: this module is engine code.
"""

from __future__ import annotations

import base64
import datetime
import html
import io
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from .design import DESIGN_PARAMETERS, QUALITY_DIGITS, QUALITY_LABELS, applied_parameters, differing_parameters
from .sweep import SWEEP_PARAMETERS

__all__ = ["report_html", "write_report", "shared_scale", "map_top", "scale_top", "png_data_uri", "colour_map", "quality_cell", "design_colours"]

#: Colours of designs in plots (matplotlib's tab10, first five).
DESIGN_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd")
_SKIP = ("wavelength", "metric")


def shared_scale(maps, percentile=99.0):
    """Top of one colour scale for several dE maps: the largest ``percentile`` over all, rounded up to 5 (min 5)."""
    return scale_top([map_top(m, percentile) for m in maps if m is not None and np.size(m)])


def map_top(values, percentile=99.0):
    """One dE map's part of :func:`shared_scale`: its ``percentile`` (NaN ignored)."""
    return float(np.nanpercentile(values, percentile))


def scale_top(tops):
    """:func:`shared_scale` from the maps' :func:`map_top` values: the largest, rounded up to 5 (min 5).

    Examples
    --------
    >>> scale_top([3.2, 11.0]), scale_top([])
    (15.0, 5.0)
    """
    top = max(tops, default=0.0)
    return float(max(5.0, 5.0 * np.ceil(top / 5.0)))


def colour_map(values, top, cmap="inferno"):
    """(H, W, 3) uint8 picture of a dE map on the scale [0, top] (matplotlib colour map)."""
    from matplotlib import colormaps

    v = np.clip(np.nan_to_num(np.asarray(values, float) / top), 0.0, 1.0)
    return (colormaps[cmap](v)[..., :3] * 255 + 0.5).astype(np.uint8)


def png_data_uri(rgb):
    """A ``data:image/png;base64,...`` URI of an (H, W, 3) image (uint8, or floats 0..255)."""
    from PIL import Image

    a = np.clip(np.rint(np.asarray(rgb, float)), 0, 255).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(a).save(buf, "PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _figure_uri(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, bbox_inches="tight")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def design_colours(names, more=()):
    """Each design's colour, by name: one colour per design in every plot of a comparison.

    Parameters
    ----------
    names : sequence of str
        The designs compared, in order; the i-th distinct name gets ``DESIGN_COLOURS[i]`` (cycling).
    more : sequence of str, optional
        Further names (e.g. a sweep's designs not among ``names``), given the next colours.

    Returns
    -------
    dict
        name -> hex colour.

    Examples
    --------
    >>> design_colours(["live", "DCS-200"], more=["DCS-200", "cones"])
    {'live': '#1f77b4', 'DCS-200': '#ff7f0e', 'cones': '#2ca02c'}
    """
    out = {}
    for name in [*names, *more]:
        if name not in out:
            out[name] = DESIGN_COLOURS[len(out) % len(DESIGN_COLOURS)]
    return out


def _histogram_uri(results, metric, colours, bins=60, top=30.0):
    """Overlaid dE histograms (one step curve per design, mean solid, median dashed)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 3.2))
    ax = fig.add_subplot()
    edges = np.linspace(0, top, bins + 1)
    for r in results:
        v = r.error_map(metric)
        v = v[np.isfinite(v)]
        c = colours[r.name]
        counts, _ = np.histogram(np.clip(v, 0, top), edges)
        ax.stairs(counts / v.size, edges, color=c, label=f"{r.name}: mean {r.measure(metric):.2f}, "
                                                           f"median {r.measure(metric, 'median'):.2f}")
        ax.axvline(r.measure(metric), color=c, lw=1)
        ax.axvline(r.measure(metric, "median"), color=c, lw=1, ls="--")
    ax.set_xlabel(f"{metric} dE (values above {top:g} in the last bin)")
    ax.set_ylabel("fraction of pixels")
    ax.legend(fontsize=8)
    return _figure_uri(fig)


def _sweep_uri(points, parameter, metric, colours):
    """Mean error against the swept parameter, one curve per design (in the design's colour of the report)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 3.2))
    ax = fig.add_subplot()
    for i, name in _designs_of(points):
        pts = sorted((p.value, p.measure(metric)) for p in points if p.design == i and p.measures)
        if pts:
            x, y = zip(*pts)
            ax.plot(x, y, "o-", color=colours[name], label=name)
    ax.set_xlabel(SWEEP_PARAMETERS.get(parameter, parameter))
    ax.set_ylabel(f"mean {metric} dE")
    ax.legend(fontsize=8)
    return _figure_uri(fig)


def _designs_of(points):
    seen = {}
    for p in points:
        seen.setdefault(p.design, p.name)
    return sorted(seen.items())


def _fmt(v, digits=2):
    return "n/a" if v is None else f"{v:.{digits}f}"


def quality_cell(result, key):
    """A table cell with a design's image-quality measure ``key`` (n/a where its scene does not allow it)."""
    if key not in result.quality:
        return "<td>n/a</td>"
    v = result.quality[key]
    return f'<td class="num" data-value="{v!r}">{v:.{QUALITY_DIGITS[key]}f}</td>'


def _cell(v):
    """A table cell with the number shown to 2 decimals and in full in ``data-value``."""
    if v is None:
        return "<td>n/a</td>"
    return f'<td class="num" data-value="{v!r}">{v:.2f}</td>'


def _value(v):
    """A parameter's value as one text whatever its type: 0 and 0.0 both "0" (they are one value); None (a
    parameter that does not apply to the design's camera, :func:`~camsim_core.review.design.applied_parameters`)
    a dash."""
    if v is None:
        return "\u2014"
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return html.escape(f"{v:g}")
    return html.escape(v if isinstance(v, str) else json.dumps(v))


def _version():
    from .. import __version__

    return __version__


def report_html(results, *, sweep=None, points=None, ab=None, title="camsim design review", metric="CIELAB"):
    """The report as one HTML string.

    Parameters
    ----------
    results : list of DesignResult
    sweep : dict, optional
        ``{"parameter", "values"}`` of the sweep whose ``points`` (SweepPoint list) are shown.
    ab : dict, optional
        :func:`~camsim_core.review.difference.ab_difference` of the first two designs.
    metric : str
        "CIELAB" or "S-CIELAB": the histograms and the sweep plot.
    """
    if not results:
        raise ParameterError("designs", "a report needs at least one design")
    e = html.escape
    colours = design_colours([r.name for r in results], more=[name for _, name in _designs_of(points or [])])
    # one colour scale per metric, over every design's map of it: the scale the explorer's Compare tab shows that
    # metric's maps on (one scale over both metrics' maps drew the CIELAB maps up to 1.7 times darker than the page)
    tops = {"CIELAB": shared_scale([r.delta_e for r in results])}
    if any(r.scielab is not None for r in results):
        tops["S-CIELAB"] = shared_scale([r.scielab for r in results if r.scielab is not None])
    top = tops.get(metric, tops["CIELAB"])
    scenes = sorted({r.scene_name or str(r.params.get("scene")) for r in results})
    quality = [k for k in QUALITY_LABELS if any(k in r.quality for r in results)]  # what the scene allows
    rows = []
    for r in results:
        m = r.measures
        s = m.get("scielab", {})
        cells = "".join(quality_cell(r, k) for k in quality)
        warn = "".join(f' <strong class="flag" style="color:#c00000">&#9888; {e(f)}</strong>' for f in r.flags)
        rows.append(f"<tr><th>{e(r.name)}{warn}</th>{_cell(m['cielab']['mean'])}{_cell(m['cielab']['median'])}"
                    f"{_cell(m['cielab']['p95'])}{_cell(s.get('mean'))}{_cell(s.get('median'))}{_cell(s.get('p95'))}"
                    f"{cells}</tr>")
    measures_table = (
        '<table class="measures" id="measures"><thead><tr><th>design</th><th>mean dE</th><th>median dE</th>'
        "<th>95th pct dE</th><th>mean S-CIELAB dE</th><th>median S-CIELAB dE</th><th>95th pct S-CIELAB dE</th>"
        + "".join(f"<th>{e(QUALITY_LABELS[k])}</th>" for k in quality)
        + "</tr></thead><tbody>" + "".join(rows) + "</tbody></table>")
    params = [applied_parameters(r.params) for r in results]  # a parameter the camera does not use: a dash
    differ = differing_parameters(params, skip=_SKIP)
    head = "".join(f"<th>{e(r.name)}</th>" for r in results)

    def param_rows(names):
        return "".join(f"<tr><th>{e(k)}</th>" + "".join(f"<td>{_value(p.get(k))}</td>" for p in params) + "</tr>"
                       for k in names)

    differ_table = (f'<table class="differ" id="differ"><thead><tr><th>parameter</th>{head}</tr></thead><tbody>'
                    + (param_rows(differ) or f'<tr><td colspan="{len(results) + 1}">none: the designs are identical</td></tr>')
                    + "</tbody></table>")
    all_table = (f'<table class="all" id="all-parameters"><thead><tr><th>parameter</th>{head}</tr></thead><tbody>'
                 + param_rows([k for k in DESIGN_PARAMETERS if k not in _SKIP]) + "</tbody></table>")
    figures = []
    for i, r in enumerate(results):
        imgs = [(png_data_uri(r.rendered), "rendered"),
                (png_data_uri(colour_map(r.delta_e, tops["CIELAB"])), f"CIELAB dE map (0 to {tops['CIELAB']:g})")]
        if r.scielab is not None:
            imgs.append((png_data_uri(colour_map(r.scielab, tops["S-CIELAB"])),
                         f"S-CIELAB dE map (0 to {tops['S-CIELAB']:g})"))
        cells = "".join(f'<figure><img src="{u}" alt="{e(r.name)}: {c}" title="{e(r.name)}: {c}">'
                        f"<figcaption>{c}</figcaption></figure>" for u, c in imgs)
        colour = colours[r.name]
        figures.append(f'<section class="design"><h3 style="border-left: 6px solid {colour}">{e(r.name)} '
                       f"<small>mean dE {_fmt(r.measure('CIELAB'))}, median {_fmt(r.measure('CIELAB', 'median'))}"
                       f"</small></h3><div class=row>{cells}</div></section>")
    ideal = (f'<figure><img src="{png_data_uri(results[0].ideal)}" alt="ideal image" title="ideal image">'
             f"<figcaption>ideal image ({e(results[0].name)}'s geometry)</figcaption></figure>")
    bar = np.repeat(colour_map(np.linspace(0, 1, 256)[None, :], 1.0), 16, axis=0)
    scales = "; ".join(f"{m} maps 0 to {t:g}" for m, t in tops.items())
    colourbar = (f'<figure class="bar"><img src="{png_data_uri(bar)}" alt="colour scale" width="256" height="16">'
                 f"<figcaption>dE, 0 to the top of each metric's scale: {scales} (the 99th percentile of every "
                 "design's map of it, rounded up to 5, as the explorer's Compare tab shows them)</figcaption></figure>")
    sections = [
        f"<h2>Measures</h2><p>Against the ideal image (the scene through the camera's geometry with cone sensors, "
        f"no mosaic, no noise). dE is CIELAB dE*ab (CIE 1976) per pixel.</p>{measures_table}",
        f"<h2>Parameters that differ</h2>{differ_table}",
        f"<h2>Images</h2><div class=row>{ideal}{colourbar}</div>" + "".join(figures),
        f'<h2>dE histograms</h2><img class="plot" src="{_histogram_uri(results, metric, colours)}" alt="{metric} dE histograms">',
    ]
    data = {"camsim_version": _version(), "scenes": scenes, "metric": metric, "scale_top": top, "scale_tops": tops,
            "designs": [{"name": r.name, "params": r.params, "measures": r.measures, "flags": list(r.flags)}
                        for r in results]}
    if ab is not None and len(results) >= 2:
        a, b = results[0], results[1]
        ab_top = shared_scale([ab["delta_e"]])
        wins = np.where(ab["a_wins"][..., None], np.array([31, 119, 180]), np.array([255, 127, 14]))
        tie = (a.error_map(metric) == b.error_map(metric))
        wins[tie] = 200
        sections.append(
            f"<h2>A/B difference: {e(a.name)} against {e(b.name)}</h2><p>dE*ab between the two renderings: mean "
            f"{_fmt(ab['measures']['mean'])}, median {_fmt(ab['measures']['median'])}. {e(a.name)} is closer to the "
            f"ideal image (by {e(metric)} dE) on {100 * ab['a_wins_fraction']:.1f} % of the pixels (blue), {e(b.name)} on "
            f"{100 * ab['b_wins_fraction']:.1f} % (orange; ties grey).</p><div class=row>"
            f'<figure><img src="{png_data_uri(colour_map(ab["delta_e"], ab_top))}" alt="A/B dE"><figcaption>dE between '
            f"the renderings (0 to {ab_top:g}, its own scale, as in the explorer)</figcaption></figure>"
            f"<figure><img src=\"{png_data_uri(wins)}\" alt=\"which design wins\">"
            f"<figcaption>which design is closer to the ideal image</figcaption></figure></div>")
        data["ab"] = {"a": a.name, "b": b.name, "measures": ab["measures"],
                      "a_wins_fraction": ab["a_wins_fraction"], "b_wins_fraction": ab["b_wins_fraction"]}
    if sweep is not None and points:
        parameter = sweep["parameter"]
        prow = "".join(
            f"<tr><th>{e(p.name)}</th><td>{p.value:g}</td>"
            + (f"{_cell(p.measure('CIELAB'))}{_cell(p.measure('CIELAB', 'median'))}{_cell(p.measure('S-CIELAB'))}"
               if p.measures else f'<td colspan="3">{e(p.error or "")}</td>') + "</tr>"
            for p in sorted(points, key=lambda p: (p.design, p.value)))
        sections.append(
            f"<h2>Sweep of {e(SWEEP_PARAMETERS.get(parameter, parameter))}</h2>"
            f'<img class="plot" src="{_sweep_uri(points, parameter, metric, colours)}" alt="sweep plot">'
            f'<table class="sweep" id="sweep"><thead><tr><th>design</th><th>{e(parameter)}</th><th>mean dE</th>'
            f"<th>median dE</th><th>mean S-CIELAB dE</th></tr></thead><tbody>{prow}</tbody></table>")
        data["sweep"] = {"parameter": parameter, "values": list(sweep["values"]),
                         "points": [{"design": p.name, "value": p.value, "measures": p.measures, "error": p.error}
                                    for p in points]}
    sections.append(f"<h2>Every parameter</h2>{all_table}")
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    payload = json.dumps(data, indent=1).replace("</", "<\\/")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{e(title)}</title>
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; img-src data:; style-src 'unsafe-inline'">
<style>
body {{ font-family: sans-serif; margin: 1.5em; color: #222; }}
table {{ border-collapse: collapse; margin: 0.5em 0 1em; }}
th, td {{ border: 1px solid #ccc; padding: 3px 8px; text-align: left; }}
td.num {{ text-align: right; font-variant-numeric: tabular-nums; }}
.row {{ display: flex; flex-wrap: wrap; gap: 12px; align-items: flex-start; }}
figure {{ margin: 0; }} figcaption {{ font-size: 0.85em; color: #555; }}
section.design h3 {{ padding-left: 6px; }} img {{ image-rendering: pixelated; max-width: 100%; }}
</style></head><body>
<h1>{e(title)}</h1>
<p class="meta">camsim {e(_version())} · scene {e(", ".join(scenes))} · {len(results)} design(s) · {when}</p>
{"".join(sections)}
<script type="application/json" id="camsim-report-data">{payload}</script>
</body></html>
"""


def write_report(path, results, **kw):
    """Write :func:`report_html` to ``path`` atomically (a temporary file renamed: never a partial report)."""
    path = Path(path)
    text = report_html(results, **kw)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ParameterError("--out", f"{path}: the folder {folder} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # a normal file, not mkstemp's private one
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
