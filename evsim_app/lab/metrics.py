"""The reconstruction scores the lab shows: the one place the lab imports akf's metrics (akf.metrics today)."""

from __future__ import annotations

from akf.metrics import log_rmse

__all__ = ["log_rmse"]
