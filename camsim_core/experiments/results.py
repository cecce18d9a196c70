"""Records of an experiment: mean and standard deviation over seeds, CSV files, text tables."""

from __future__ import annotations

import csv
import io
import math
from collections import OrderedDict

import numpy as np

from ..io.output import atomic_write

__all__ = ["summarize", "write_csv", "format_mean_std"]


def summarize(records, by, values, *, value_name="method"):
    """Mean and sample standard deviation over the records sharing the keys ``by``.

    Parameters
    ----------
    records : list of dict
        One per task.
    by : sequence of str
        Keys that identify a point (e.g. scene, alpha, sigma); the seed index is
        what varies within a group.
    values : sequence of str
        Keys holding the measured numbers; each gives its own summary row,
        with ``value_name`` set to the key.

    Returns
    -------
    list of dict
        ``{**by, value_name, "mean", "std", "n"}`` in first-seen order of the
        groups; ``std`` (ddof=1) is NaN when a group has one record.
    """
    groups = OrderedDict()
    for r in records:
        groups.setdefault(tuple(r[k] for k in by), []).append(r)
    rows = []
    for key, group in groups.items():
        for v in values:
            x = np.array([g[v] for g in group], float)
            rows.append(
                {
                    **dict(zip(by, key)),
                    value_name: v,
                    "mean": float(x.mean()),
                    "std": float(x.std(ddof=1)) if x.size > 1 else math.nan,
                    "n": int(x.size),
                }
            )
    return rows


def write_csv(rows, path, columns=None):
    """Write ``rows`` (list of dict) as CSV, atomically; floats with full precision."""
    columns = list(columns or (rows[0].keys() if rows else []))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in r.items()})
    text = buf.getvalue().encode()
    return atomic_write(path, lambda f: f.write(text))


def format_mean_std(mean, std, digits=2):
    """``"2.37 ± 0.05"``, or just the mean when the std is undefined (one seed)."""
    if std is None or not math.isfinite(std):
        return f"{mean:.{digits}f}"
    return f"{mean:.{digits}f} ± {std:.{digits}f}"
