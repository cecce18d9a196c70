"""``camsim report``: camera designs (explorer parameter files) compared in one self-contained HTML report."""

from __future__ import annotations

from pathlib import Path

from ..errors import ParameterError

__all__ = ["register", "run", "MAX_REPORT_DESIGNS"]

#: Designs in one report (each keeps a few images in memory while the report is written).
MAX_REPORT_DESIGNS = 12


def register(subparsers):
    p = subparsers.add_parser(
        "report",
        help="compare camera designs in a self-contained HTML report",
        description="Evaluate each DESIGN.json (the explorer's parameters file: its JSON download) on its scene "
        "and write one HTML file with every image embedded: rendered images and dE maps on one scale, mean, "
        "median and 95th percentile of CIELAB and S-CIELAB dE, the parameters that differ, the dE histograms, "
        "the A/B difference of the first two designs, and the sweep (from a file or --sweep).",
    )
    p.add_argument("designs", nargs="+", metavar="DESIGN.json", help="explorer parameter files (pinned designs included)")
    p.add_argument("--out", required=True, help="the report, .html")
    p.add_argument("--sweep", metavar="PARAM=V1,V2,...",
                   help="sweep one parameter over these values for every design (e.g. noise_sigma=0,2,4,6,8)")
    p.add_argument("--metric", choices=("CIELAB", "S-CIELAB"), default="CIELAB", help="error of the histograms and sweep plot")
    p.add_argument("--workers", type=int, default=2, help="threads of the sweep (default 2)")
    p.add_argument("--title", default="camsim design review", help="the report's title")
    p.set_defaults(func=run)


def _parse_sweep(text):
    from ..review.sweep import check_sweep

    name, sep, values = str(text).partition("=")
    if not sep:
        raise ParameterError("--sweep", f"expected PARAM=V1,V2,... got {text!r}")
    return check_sweep({"parameter": name.strip(), "values": values}, where="--sweep")


def run(args):
    from ..review import evaluate_design, read_design_file, run_sweep
    from ..review.difference import ab_difference
    from ..review.report import write_report

    out = Path(args.out)
    if out.suffix.lower() not in (".html", ".htm"):
        raise ParameterError("--out", f"{out.name}: expected an .html file name")
    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise ParameterError("--out", f"{out}: the folder {out.parent} does not exist")
    if args.workers < 1:
        raise ParameterError("--workers", f"must be >= 1, got {args.workers}")
    sweep = _parse_sweep(args.sweep) if args.sweep else None
    designs, names = [], set()
    for path in args.designs:  # read and check every file before computing anything
        file_designs, file_sweep = read_design_file(path)
        for name, params in file_designs:
            unique, k = name, 2
            while unique in names:
                unique, k = f"{name} ({k})", k + 1
            names.add(unique)
            designs.append((unique, params))
        sweep = sweep or file_sweep
    if len(designs) > MAX_REPORT_DESIGNS:
        raise ParameterError("DESIGN.json", f"at most {MAX_REPORT_DESIGNS} designs in one report, got {len(designs)}")
    results = [evaluate_design(params, name) for name, params in designs]
    points = None
    if sweep is not None:
        metrics = ("cielab",) if args.metric == "CIELAB" else ("cielab", "scielab")  # the plotted error only
        points = run_sweep(designs, sweep["parameter"], sweep["values"], max_workers=args.workers, metrics=metrics)
    ab = None
    if len(results) >= 2 and results[0].shape == results[1].shape and (results[0].white == results[1].white).all():
        ab = ab_difference(results[0], results[1], args.metric)
    write_report(out, results, sweep=sweep, points=points, ab=ab, title=args.title, metric=args.metric)
    for r in results:
        print(f"{r.name}: mean dE {r.measure('CIELAB'):.2f}, median {r.measure('CIELAB', 'median'):.2f}")
    print(f"wrote {out} ({len(results)} design(s){', sweep of ' + sweep['parameter'] if sweep else ''})")
    return 0
