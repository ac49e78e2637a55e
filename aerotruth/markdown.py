"""Markdown rendering of small tables for reports (no extra dependency)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd


def format_value(v: object, digits: int = 4) -> str:
    """Numbers to `digits` significant digits, NaN/None as an en dash, the rest as str."""
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "–"
        return f"{v:.{digits}g}"
    if isinstance(v, np.integer):
        return str(int(v))
    if isinstance(v, np.floating):
        return format_value(float(v), digits)
    if isinstance(v, np.bool_):
        return format_value(bool(v), digits)
    return str(v).replace("|", "\\|")


def to_markdown(df: pd.DataFrame, digits: int = 4) -> str:
    """A GitHub-flavoured Markdown table of `df` (index not shown)."""
    cols = [str(c) for c in df.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for row in df.itertuples(index=False):
        lines.append("| " + " | ".join(format_value(v, digits) for v in row) + " |")
    return "\n".join(lines)
