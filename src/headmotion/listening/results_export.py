"""A listening test's results as one JSON document or one CSV table, for the admin API and
:mod:`headmotion.listening.analysis`."""

from __future__ import annotations

import csv
import io
import time
from typing import Any

from .config import TestConfig
from .db import ANSWER_COLUMNS, Database

def results_document(cfg: TestConfig, db: Database) -> dict[str, Any]:
    """Everything the analysis needs: test settings, participants (demographics) and answers."""
    return {
        "format": "headmotion-listening-results/1",
        "exported_at": time.time(),
        "test": {"name": cfg.name, "type": cfg.type, "title": cfg.title, "digest": cfg.digest,
                 "scale_points": cfg.scale_points, "hidden_reference": cfg.hidden_reference,
                 "anchor": cfg.anchor, "screening_threshold": cfg.screening_threshold,
                 "screening_fraction": cfg.screening_fraction,
                 "demographics": [q.name for q in cfg.demographics]},
        "participants": db.progress(),
        "answers": db.answer_rows(),
    }


def results_csv(db: Database) -> str:
    """Every answer as one CSV row (the answer columns, then each demographics answer)."""
    rows = db.answer_rows()
    demo = sorted({k for r in rows for k in r if k.startswith("demo_")})
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(ANSWER_COLUMNS) + demo, extrasaction="ignore",
                       lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    return buf.getvalue()


__all__ = ["results_document", "results_csv"]
