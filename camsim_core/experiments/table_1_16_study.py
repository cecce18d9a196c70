"""Table 1.16 reproduced or explained: a sweep of the choices the chapter leaves unstated (issue 41).

The chapter's mosaic experiment (section 5, Table 1.16; :mod:`.mosaic`)
finds that three sensors on a Bayer tile beat four on a square grid once
the noise reaches sigma = 5. It does not say how much of the 0-255 range
the image filled, where three of the four Gaussian sensors were centred nor
how they were scaled, the Bayesian demosaic's prior and noise model, the
S-CIELAB viewing geometry, or the details of the illuminant-based rendering.
This study sweeps them:

=====================  =====================================================
choice                 values (defaults of :data:`GRID`)
=====================  =====================================================
``exposure_fill``      0.9 (camsim's), 0.6, 0.4, 0.3, 0.2, 0.15, 0.1, 0.05
                       of the 0-255 range (99.5th percentile, brightest sensor)
``centers``            eight sets of classes 1-4 (520 nm fixed, the chapter's):
                       evenly spaced 50-90 nm apart, and three uneven ones
``normalization``      ``area`` (equal areas), ``white`` (white-balanced gains)
demosaic               bilinear; Bayesian with/without the detail prior,
                       with the noise known or ignored; Brainard's original
rendering              illuminant-based, N-D (N sensors) or 3-D surface model
``viewing``            camera (102.6 samples/deg), camera/2, /4, /10
=====================  =====================================================

One **task** is one (exposure fill, centres, normalization, demosaic,
rendering): it simulates, demosaics and renders both designs at the three
noise levels (six images) and measures each against the ideal image under
every viewing, so it yields one **combination** (the six table cells) per
viewing. For each combination: the six cells, their RMS and largest
difference from the chapter's, and whether the crossover appears (four
sensors better at sigma 0, three better at sigma 5).

Resumable: each finished task appends its combinations, one JSON line each,
to ``study.jsonl`` in the output folder; a rerun skips the tasks already
there. Tasks run on a local Dask cluster (``workers``) or on any Dask
scheduler (``scheduler="tcp://host:8786"``), with a tqdm progress bar.

Programmatic use::

    from camsim_core.experiments import table_1_16_study as study
    tasks = study.tasks(fills=(0.9, 0.2))
    study.run(tasks, "out", workers=2)
    rows = study.load("out")
    print(study.best(rows, 3))
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import random
import time
from dataclasses import asdict, dataclass, replace
from functools import lru_cache
from pathlib import Path

from ..errors import ParameterError
from . import mosaic
from .grid import DEFAULT_DISTANCE, DEFAULT_MONITOR

__all__ = [
    "StudyTask",
    "GRID",
    "VIEWINGS",
    "CHAPTER",
    "CELLS",
    "tasks",
    "evaluate",
    "run",
    "load",
    "best",
    "crossover",
    "choice_effects",
    "RESULTS_NAME",
    "rises",
    "markdown",
    "write_report",
    "summary_text",
]

#: The six cells in the table's order: (sensors, sigma).
CELLS = ((3, 0.0), (3, 2.0), (3, 5.0), (4, 0.0), (4, 2.0), (4, 5.0))
#: The chapter's six numbers in that order.
CHAPTER = tuple(mosaic.CHAPTER_TABLE[n][s] for n, s in CELLS)
#: S-CIELAB viewings measured by every task: the camera's angular resolution (102.6 samples/deg) and coarser.
VIEWINGS = ("camera", "camera/2", "camera/4", "camera/10")
#: Demosaic variants: (method, prior_detail, noise_model).
DEMOSAICS = (
    ("bilinear", None, None),
    ("bayesian", 0.1, "known"),  # camsim's default
    ("bayesian", 0.0, "known"),  # the image-estimated prior alone
    ("bayesian", 0.1, "ignored"),  # the demosaic does not know the noise
    ("bayesian", 0.0, "ignored"),
    ("bayesian-original", None, "fraction"),  # Brainard's: 5 x 5, one mean, noise a fixed 1 % of the prior variance
)
#: Renderings: (method, surface dimensions; None = as many as sensors).
RENDERINGS = (("illuminant", None), ("illuminant", 3))
#: The default study grid.
GRID = {
    "fills": (0.9, 0.6, 0.4, 0.3, 0.2, 0.15, 0.1, 0.05),
    # evenly spaced about 520 nm (spacing 50-90 nm; 60 is camsim's default) and three uneven sets
    "centers": tuple((520.0 - d, 520.0, 520.0 + d, 520.0 + 2 * d) for d in (50.0, 60.0, 70.0, 80.0, 90.0))
    + ((440.0, 520.0, 570.0, 620.0), (450.0, 520.0, 590.0, 650.0), (470.0, 520.0, 580.0, 630.0)),
    "normalizations": ("area", "white"),
    "demosaics": DEMOSAICS,
    "renderings": RENDERINGS,
    "viewings": VIEWINGS,
}
#: Results file in the output folder (one JSON line per combination).
RESULTS_NAME = "study.jsonl"


@dataclass(frozen=True)
class StudyTask:
    """One task: a reading of the unstated choices except the viewing, measured under every viewing."""

    scene: str = "cacaphony290"
    exposure_fill: float = mosaic.EXPOSURE_FILL
    centers: tuple = mosaic.CENTERS
    normalization: str = "area"
    demosaic: str = "bayesian"
    prior_detail: float | None = None
    noise_model: str | None = None
    rendering: str = "illuminant"
    surface_dimensions: int | None = None
    viewings: tuple = VIEWINGS
    distance: float = DEFAULT_DISTANCE
    monitor: str = DEFAULT_MONITOR
    seed: int = 0

    @property
    def key(self):
        """16 hex digits of a SHA-256 of the task's choices: the key of resumption."""
        d = asdict(self)
        d["centers"] = "/".join(f"{c:g}" for c in self.centers)
        d["viewings"] = ",".join(self.viewings)
        return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]


def tasks(*, scene="cacaphony290", fills=GRID["fills"], centers=GRID["centers"], normalizations=GRID["normalizations"],
          demosaics=GRID["demosaics"], renderings=GRID["renderings"], viewings=GRID["viewings"], shuffle=0):
    """The study's tasks, validated (every option checked by :func:`.mosaic.check_options` before any runs).

    Tasks sharing an exposure (fill, centres, normalization) are kept next to
    each other (their ideal image is computed once per worker); the groups are
    put in a random order fixed by ``shuffle`` (None: grid order), so that a
    run stopped early has sampled the whole grid evenly.

    Returns
    -------
    list of StudyTask
    """
    from ._evaluation import check_viewing
    from .grid import check_centers, check_scenes

    check_scenes([scene])
    viewings = tuple(check_viewing(v) for v in viewings)
    if not viewings or len(set(viewings)) != len(viewings):
        raise ParameterError("viewings", f"give distinct viewings, got {list(viewings)}")
    groups = []
    for fill, c, norm in itertools.product(fills, centers, normalizations):
        c = tuple(check_centers(c, "centers"))
        group = []
        for (dem, detail, noise), (ren, dims) in itertools.product(demosaics, renderings):
            o = mosaic.check_options(demosaic=dem, exposure_fill=fill, normalization=norm, prior_detail=detail,
                                     noise_model=noise, rendering=ren, surface_dimensions=dims)
            group.append(StudyTask(scene, o["exposure_fill"], c, norm, dem, o["prior_detail"], noise, ren, o["surface_dimensions"],
                                   viewings))
        groups.append(group)
    if shuffle is not None:
        random.Random(shuffle).shuffle(groups)
    return [t for g in groups for t in g]


@lru_cache(maxsize=16)
def _exposure(scene, centers, distance, fill, normalization):
    from ..scene import load_scene

    return mosaic.design_exposure(load_scene(scene), centers, mosaic.STD_NM, distance, fill, normalization)


def crossover(cells):
    """Whether six cells (:data:`CELLS` order) show the chapter's crossover: 4 < 3 at sigma 0 and 3 < 4 at sigma 5."""
    return bool(cells[3] < cells[0] and cells[2] < cells[5])


def _compare(cells):
    diff = [c - r for c, r in zip(cells, CHAPTER)]
    return math.sqrt(sum(d * d for d in diff) / len(diff)), max(abs(d) for d in diff)


def evaluate(task):
    """Run one task: six images, each measured under every viewing.

    Returns
    -------
    list of dict
        One per viewing: the task's choices, ``viewing``, ``samples_per_degree``,
        ``exposure`` (s), ``cells`` (six mean S-CIELAB dE*ab, :data:`CELLS` order),
        ``rms`` and ``max_abs`` (dE against :data:`CHAPTER`), ``crossover``,
        ``task`` (the key) and ``seconds`` (of the whole task).
    """
    from ._evaluation import mean_scielab, viewing_rate

    t0 = time.perf_counter()
    exposure = _exposure(task.scene, task.centers, task.distance, task.exposure_fill, task.normalization)
    errors = {v: [] for v in task.viewings}
    rates = {}
    for n, sigma in CELLS:
        config = mosaic.MosaicConfig(task.scene, n, sigma, task.seed, exposure, task.distance, task.monitor, task.centers,
                                     mosaic.STD_NM, task.demosaic, task.viewings[0], task.exposure_fill, task.normalization,
                                     task.prior_detail, task.noise_model, task.rendering, task.surface_dimensions)
        xyz = mosaic.rendered_xyz(config)
        ideal_xyz, white, camera_rate = mosaic.ideal(config)
        for v in task.viewings:
            spd, _ = viewing_rate(v, camera_rate)
            rates[v] = spd
            errors[v].append(mean_scielab(xyz, ideal_xyz, spd, white))
    seconds = time.perf_counter() - t0
    base = asdict(task)
    del base["viewings"]
    base["centers"] = "/".join(f"{c:g}" for c in task.centers)
    out = []
    for v in task.viewings:
        cells = errors[v]
        rms, worst = _compare(cells)
        out.append({**base, "viewing": v, "samples_per_degree": rates[v], "exposure": exposure, "cells": cells, "rms": rms,
                    "max_abs": worst, "crossover": crossover(cells), "task": task.key, "seconds": seconds})
    return out


def load(folder):
    """The combinations finished so far in ``folder`` (a list of dicts).

    A line cut short by an interrupted run is skipped; a combination written
    twice (its task rerun after a partial write) counts once, the last copy.
    """
    path = Path(folder) / RESULTS_NAME
    rows = {}
    if path.exists():
        for line in path.read_text().splitlines():
            try:
                r = json.loads(line)
                rows[r["task"], r["viewing"]] = r
            except (json.JSONDecodeError, KeyError, TypeError):
                continue
    return list(rows.values())


def _done(folder, task_list):
    """Keys of the tasks whose every viewing is in the results."""
    count = {}
    for r in load(folder):
        count[r["task"]] = count.get(r["task"], 0) + 1
    return {t.key for t in task_list if count.get(t.key, 0) >= len(t.viewings)}


def run(task_list, folder, *, workers=2, scheduler=None, limit=None, progress=None, processes=True, function=evaluate):
    """Run the tasks not yet in ``folder``/study.jsonl, appending each task's combinations as it finishes.

    Parameters
    ----------
    task_list : list of StudyTask
    folder : path
        Output folder (created).
    workers : int or None
        Local Dask cluster of that many single-thread workers; None or 0 runs in this process.
    scheduler : str, optional
        Address of a running Dask scheduler (``workers`` is then ignored).
    limit : int, optional
        Run at most this many of the pending tasks.
    progress : bool or None
        tqdm bar; None = only on a terminal.
    processes : bool
        Local cluster of processes (default) or of threads of this process.

    Returns
    -------
    dict
        ``total`` tasks, ``skipped`` (already done), ``ran``, ``seconds`` (wall time).
    """
    from tqdm.auto import tqdm

    from .runner import dask_client

    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int) or limit < 1):
        raise ParameterError("limit", f"must be a whole number >= 1, got {limit!r}")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    done = _done(folder, task_list)
    pending = [t for t in task_list if t.key not in done]
    if limit is not None:
        pending = pending[:limit]
    t0 = time.perf_counter()
    path = folder / RESULTS_NAME
    if path.exists() and path.stat().st_size:
        with open(path, "rb") as f:
            f.seek(-1, 2)
            torn = f.read(1) != b"\n"
        if torn:  # end the line an interrupted run cut short, so that the next record starts on its own line
            with open(path, "a") as f:
                f.write("\n")

    def write(records):
        with open(path, "a") as f:
            for r in records:
                f.write(json.dumps(r) + "\n")

    bar = tqdm(total=len(pending), desc="table 1.16 study", unit="task", disable=None if progress is None else not progress)
    try:
        if not pending:
            pass  # nothing to run: no cluster is started, no scheduler contacted
        elif scheduler is None and not workers:
            for t in pending:
                write(function(t))
                bar.update(1)
        else:
            from distributed import as_completed

            with dask_client(workers, scheduler, processes=processes) as client:
                futures = client.map(function, pending, pure=False)
                for future in as_completed(futures):
                    write(future.result())
                    bar.update(1)
                    future.release()
    finally:
        bar.close()
    return {"total": len(task_list), "skipped": len(task_list) - len([t for t in task_list if t.key not in done]),
            "ran": len(pending), "seconds": time.perf_counter() - t0}


def best(rows, count=10, *, crossing=None):
    """The ``count`` combinations nearest the chapter (smallest RMS over the six cells).

    ``crossing=True`` keeps only those showing the crossover.
    """
    rows = [r for r in rows if crossing is None or r["crossover"] == crossing]
    return sorted(rows, key=lambda r: r["rms"])[:count]


CHOICES = ("exposure_fill", "centers", "normalization", "demosaic_variant", "rendering_variant", "viewing")


def variant(row):
    """Short names of a combination's demosaic and rendering variants."""
    dem = row["demosaic"]
    if dem == "bayesian":
        dem = f"bayesian detail {row['prior_detail']:g} noise {row['noise_model']}"
    ren = row["rendering"] + (f" {row['surface_dimensions']}-D" if row.get("surface_dimensions") else " N-D")
    return dem, ren


def choice_effects(rows):
    """For each unstated choice and value: mean over the rest of the grid of the 4-minus-3 gap at sigma 0 and 5,
    of each design's rise from sigma 0 to 5, the share of combinations with the crossover, and the best RMS.

    Returns
    -------
    list of dict
    """
    out = []
    for choice in CHOICES:
        groups = {}
        for r in rows:
            dem, ren = variant(r)
            value = {"demosaic_variant": dem, "rendering_variant": ren}.get(choice, r.get(choice))
            groups.setdefault(value, []).append(r)
        for value, rs in groups.items():
            n = len(rs)
            mean = lambda f: sum(f(r["cells"]) for r in rs) / n  # noqa: E731
            out.append({"choice": choice, "value": value, "n": n,
                        "gap_sigma0": mean(lambda c: c[3] - c[0]), "gap_sigma5": mean(lambda c: c[5] - c[2]),
                        "rise3": mean(lambda c: c[2] - c[0]), "rise4": mean(lambda c: c[5] - c[3]),
                        "crossover_share": sum(r["crossover"] for r in rs) / n, "best_rms": min(r["rms"] for r in rs)})
    return out


def _cells_text(cells):
    return " ".join(f"{c:.2f}" for c in cells)


def describe(row):
    """One line naming a combination's choices."""
    dem, ren = variant(row)
    return (f"fill {row['exposure_fill']:g}, centres {row['centers']}, {row['normalization']}, {dem}, {ren}, "
            f"{row['viewing']} ({row['samples_per_degree']:.4g} samples/deg)")


def summary_text(rows, count=5):
    """A plain-text summary: counts, the best combinations (overall and with the crossover) beside the chapter's cells."""
    n = len(rows)
    crossing = [r for r in rows if r["crossover"]]
    close = [r for r in rows if r["max_abs"] <= 0.5]
    lines = [f"{n} combinations; crossover in {len(crossing)}; all six cells within 0.5 dE of the chapter's in {len(close)} "
             f"(of which {sum(r['crossover'] for r in close)} with the crossover)",
             f"chapter            3 sensors {_cells_text(CHAPTER[:3])} | 4 sensors {_cells_text(CHAPTER[3:])}"]
    for title, subset in (("nearest the chapter", rows), ("nearest with the crossover", crossing)):
        lines.append(f"{title}:")
        for r in best(subset, count):
            lines.append(f"  rms {r['rms']:.2f} max {r['max_abs']:.2f}  3 sensors {_cells_text(r['cells'][:3])} | "
                         f"4 sensors {_cells_text(r['cells'][3:])}  {'crossover' if r['crossover'] else 'no crossover'}  "
                         f"[{describe(r)}]")
    return "\n".join(lines)


def _flat(row):
    dem, ren = variant(row)
    out = {k: row[k] for k in ("exposure_fill", "centers", "normalization", "demosaic", "prior_detail", "noise_model",
                               "rendering", "surface_dimensions", "viewing")}
    out["samples_per_degree"] = round(row["samples_per_degree"], 4)
    out["exposure_s"] = f"{row['exposure']:.5g}"
    for (n, s), c in zip(CELLS, row["cells"]):
        out[f"s{n}_sigma{s:g}"] = round(c, 3)
    out.update(rms=round(row["rms"], 3), max_abs=round(row["max_abs"], 3), crossover=row["crossover"])
    return out


def write_report(rows, folder):
    """Write ``combinations.csv`` (every combination), ``best.csv`` (20 nearest the chapter, and 20 nearest with the
    crossover), ``effects.csv`` (:func:`choice_effects`), the figures ``effects.png`` and ``best.png`` and
    ``summary.md`` (:func:`markdown`); return the paths."""
    from .results import write_csv

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    ordered = sorted(rows, key=lambda r: r["rms"])
    paths = [write_csv([_flat(r) for r in ordered], folder / "combinations.csv")]
    top = [{"rank": i + 1, "subset": "all", **_flat(r)} for i, r in enumerate(best(rows, 20))]
    top += [{"rank": i + 1, "subset": "crossover", **_flat(r)} for i, r in enumerate(best(rows, 20, crossing=True))]
    paths.append(write_csv(top, folder / "best.csv"))
    effects = choice_effects(rows)
    paths.append(write_csv([{k: (round(v, 3) if isinstance(v, float) else v) for k, v in e.items()} for e in effects],
                           folder / "effects.csv"))
    paths += plot(rows, effects, folder)
    md = folder / "summary.md"
    md.write_text(markdown(rows))
    paths.append(md)
    return paths


def plot(rows, effects, folder):
    """The study's figures (matplotlib's object API, Agg): ``effects.png`` and ``best.png``; returns their paths."""
    from matplotlib import colormaps
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from .plot import save_png

    folder = Path(folder)
    chapter_gap0, chapter_gap5 = CHAPTER[3] - CHAPTER[0], CHAPTER[5] - CHAPTER[2]
    fig = Figure(figsize=(15, 8.5))
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 3)
    for ax, choice in zip(axes.ravel(), CHOICES):
        es = [e for e in effects if e["choice"] == choice]
        if choice == "exposure_fill":
            es.sort(key=lambda e: -e["value"])
        y = range(len(es))
        ax.scatter([e["gap_sigma0"] for e in es], y, marker="o", color="tab:blue", label="σ 0")
        ax.scatter([e["gap_sigma5"] for e in es], y, marker="s", color="tab:red", label="σ 5")
        for i, e in enumerate(es):
            ax.plot([e["gap_sigma0"], e["gap_sigma5"]], [i, i], color="0.7", zorder=0)
            ax.annotate(f"{100 * e['crossover_share']:.0f}%", (max(e["gap_sigma0"], e["gap_sigma5"]), i),
                        xytext=(4, -3), textcoords="offset points", fontsize=7)
        ax.axvline(chapter_gap0, color="tab:blue", ls=":", lw=1)
        ax.axvline(chapter_gap5, color="tab:red", ls=":", lw=1)
        ax.axvline(0, color="k", lw=0.6)
        ax.set_yticks(list(y))
        ax.set_yticklabels([str(e["value"]).replace("bayesian ", "bay. ") for e in es], fontsize=7)
        ax.set_title(choice.replace("_", " "), fontsize=10)
        ax.set_xlabel("mean dE(4 sensors) - dE(3 sensors)", fontsize=8)
    axes[0, 0].legend(fontsize=8, loc="lower left")
    fig.suptitle("Table 1.16: 4-minus-3 gap at σ 0 and σ 5 for each unstated choice, averaged over the rest of the grid "
                 "(dotted: the chapter's -1.28 and +0.12; crossover = red right of 0 and blue left of 0; % = share of "
                 "combinations with the crossover)", fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    p1 = save_png(fig, folder / "effects.png", dpi=90)

    fig = Figure(figsize=(14, 5.5))
    FigureCanvasAgg(fig)
    a1, a2 = fig.subplots(1, 2)
    sig = [0, 2, 5]
    a1.plot(sig, CHAPTER[:3], "k-o", lw=2.5, label="chapter, 3 sensors")
    a1.plot(sig, CHAPTER[3:], "k--s", lw=2.5, label="chapter, 4 sensors")
    colours = colormaps["tab10"].colors
    for i, r in enumerate(best(rows, 3) + best(rows, 2, crossing=True)):
        c = colours[i % 10]
        tag = f"#{i + 1} rms {r['rms']:.2f}" + (" (crossover)" if r["crossover"] else "")
        a1.plot(sig, r["cells"][:3], "-o", color=c, alpha=0.8, label=f"{tag}, 3 sensors")
        a1.plot(sig, r["cells"][3:], "--s", color=c, alpha=0.8)
    a1.set_xlabel("noise σ (digital units of 0-255)")
    a1.set_ylabel("mean S-CIELAB dE*ab")
    a1.set_title("best combinations (solid 3 sensors, dashed 4) beside the chapter", fontsize=10)
    a1.legend(fontsize=7)
    fills = sorted({r["exposure_fill"] for r in rows})
    cmap = colormaps["viridis"]
    for j, f in enumerate(fills):
        rs = [r for r in rows if r["exposure_fill"] == f]
        a2.scatter([r["cells"][2] - r["cells"][0] for r in rs], [r["cells"][5] - r["cells"][3] for r in rs], s=5,
                   color=cmap(j / max(1, len(fills) - 1)), alpha=0.5, label=f"fill {f:g}")
    a2.plot([CHAPTER[2] - CHAPTER[0]], [CHAPTER[5] - CHAPTER[3]], "r*", ms=14, label="chapter", zorder=5)
    lim = max(a2.get_xlim()[1], a2.get_ylim()[1])
    a2.plot([0, lim], [0, lim], color="0.5", lw=0.8)
    a2.set_xlabel("rise of the 3-sensor error from σ 0 to 5 (dE)")
    a2.set_ylabel("rise of the 4-sensor error from σ 0 to 5 (dE)")
    a2.set_title("how much noise costs each design, every combination", fontsize=10)
    a2.legend(fontsize=7)
    fig.tight_layout()
    p2 = save_png(fig, folder / "best.png", dpi=90)
    return [Path(p1), Path(p2)]


def rises(cells):
    """Each design's rise of the error from sigma 0 to sigma 5: (3 sensors, 4 sensors), dE."""
    return cells[2] - cells[0], cells[5] - cells[3]


def markdown(rows, count=10):
    """Markdown tables of the results: the combinations nearest the chapter (all, and with the crossover), those
    nearest the chapter's noise rises, and the effect of each choice (:func:`choice_effects`)."""
    head = ("| rank | rms | max | 3: σ0 | 3: σ2 | 3: σ5 | 4: σ0 | 4: σ2 | 4: σ5 | crossover | fill | centres (nm) | "
            "normalization | demosaic | rendering | viewing (samples/deg) |")
    rule = "|" + "---|" * (head.count("|") - 1)

    def line(i, r):
        dem, ren = variant(r)
        c = r["cells"]
        return (f"| {i} | {r['rms']:.2f} | {r['max_abs']:.2f} | " + " | ".join(f"{v:.2f}" for v in c)
                + f" | {'yes' if r['crossover'] else 'no'} | {r['exposure_fill']:g} | {r['centers']} | {r['normalization']} | "
                f"{dem} | {ren} | {r['viewing']} ({r['samples_per_degree']:.4g}) |")

    chapter = ("| chapter | | | " + " | ".join(f"**{v:.2f}**" for v in CHAPTER) + " | yes | | | | | | |")
    out = []
    for title, subset in (("Nearest the chapter (smallest RMS over the six cells)", rows),
                          ("Nearest the chapter among the combinations with the crossover", [r for r in rows if r["crossover"]])):
        out += [f"**{title}**", "", head, rule, chapter] + [line(i + 1, r) for i, r in enumerate(best(subset, count))] + [""]
    r3, r4 = rises(CHAPTER)
    near = sorted(rows, key=lambda r: math.hypot(rises(r["cells"])[0] - r3, rises(r["cells"])[1] - r4))[:count]
    out += [f"**Nearest the chapter's rises from σ 0 to σ 5 (3 sensors +{r3:.2f}, 4 sensors +{r4:.2f})**", "", head, rule,
            chapter] + [line(i + 1, r) for i, r in enumerate(near)] + [""]
    out += ["**Each choice, averaged over the rest of the grid** (gap = dE(4 sensors) - dE(3 sensors); the chapter's gap "
            f"is {CHAPTER[3] - CHAPTER[0]:.2f} at σ 0 and +{CHAPTER[5] - CHAPTER[2]:.2f} at σ 5, its rises +{r3:.2f} and +{r4:.2f})",
            "", "| choice | value | combinations | gap σ0 | gap σ5 | rise 3 sensors | rise 4 sensors | share with crossover | best rms |",
            "|---|---|---|---|---|---|---|---|---|"]
    for e in choice_effects(rows):
        out.append(f"| {e['choice']} | {e['value']} | {e['n']} | {e['gap_sigma0']:.2f} | {e['gap_sigma5']:.2f} | {e['rise3']:.2f} | "
                   f"{e['rise4']:.2f} | {100 * e['crossover_share']:.0f} % | {e['best_rms']:.2f} |")
    return "\n".join(out) + "\n"
