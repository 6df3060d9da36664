"""Evaluation results as text and JSON: the paper's Table 1 layout, one sequence's method-by-metric table, and
the JSON file of `evsim evaluate --json`."""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from pathlib import Path

import akf
from generators.formats.atomic import write_text_atomic

from .protocols import UNITS, WHITE


def format_table(result: dict, protocol: str = "reference", notes: Iterable[str] = ()) -> str:
    """The paper's Table 1 layout: one block per metric, a row per sequence and the mean, a column per method."""
    methods = list(result)
    sequences = list(result[methods[0]])
    metrics = list(result[methods[0]][sequences[0]])
    width = max(12, *(len(s) + 2 for s in sequences))
    lines = [f"units: {UNITS[protocol]}", *(f"note: {n}" for n in notes)]
    for metric in metrics:
        white = WHITE[protocol] if metric in akf.metrics.NEEDS_WHITE else ""
        lines += ["", f"{metric}: {akf.NORMALISATION[metric]}{white}",
                  f"{metric:<{width}}" + "".join(f"{m:>14}" for m in methods)]
        for seq in sequences:
            lines.append(f"{seq:<{width}}" + "".join(f"{_fmt(result[m][seq][metric]):>14}" for m in methods))
    return "\n".join(lines)


def format_scores(table: dict) -> str:
    """One sequence's {method: {metric: value}} as a method-by-metric table (evsim demo's metrics.txt)."""
    metrics = list(next(iter(table.values())))
    lines = ["method    " + "".join(f"{m:>12}" for m in metrics)]
    for method, row in table.items():
        lines.append(f"{method:<10}" + "".join(f"{_fmt(row[m]):>12}" for m in metrics))
    return "\n".join(lines)


def _fmt(v: float) -> str:
    return "inf" if math.isinf(v) else f"{v:.4g}"


def write_json(result: dict, path: str | Path, tuning: dict | None = None) -> None:
    """{method: {sequence: {metric: value}, "mean": {...}}} as JSON, atomically (inf as the string "inf"); with
    tuning ({method: setting}, DatasetScores.tuning of evsim_eval.evaluate) also a top-level "tuning" entry."""
    clean = {m: {s: {k: (str(v) if math.isinf(v) else v) for k, v in row.items()} for s, row in seqs.items()}
             for m, seqs in result.items()}
    if tuning:
        clean["tuning"] = tuning
    write_text_atomic(path, json.dumps(clean, indent=2) + "\n")
