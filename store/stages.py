"""Which studies a driver moves forward (ask/tell, stages), and which end with their last job.

A sweep or convergence study without stages is complete when its last job ends
(:func:`store.queue._finish_study_if_complete`); an optimisation, a calibration and any study
with a confirmation stage is ended by its driver (:func:`store.studies.drive`), which creates
the next stage's jobs first."""

from __future__ import annotations

from typing import Any

DRIVEN_KINDS = ("optimize", "calibrate")


def driven(kind: str | None, document: dict[str, Any] | None) -> bool:
    return kind in DRIVEN_KINDS or (kind == "sweep" and bool((document or {}).get("confirm")))
