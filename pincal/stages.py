"""The house's plan, written once: the stages in the data flow's order, the foundation modules under
them, and the modules whose ``__all__`` is public. ``pincal`` reads them (its attributes, where a
moved name is found) and so do the tests (the imports run one way, every public list imports).

Imports nothing: ``import pincal`` reads it.
"""

from __future__ import annotations

__all__ = ["FOUNDATIONS", "PUBLIC_LISTS", "STAGES"]

STAGES = (
    "model",
    "instruments",
    "evaluation",
    "planning",
    "campaign",
    "calibration",
    "adaptive",
    "export",
    "compensation",
    "viewing",
    "cli",
)
"""The stages (subpackages of pincal), in the data flow's order: each imports only those before it
(robot → what is measured → criteria → design → campaign → identification → the next poses from the
data so far → export → compensation → view → command line)."""

FOUNDATIONS = ("errors", "typing", "arguments")
"""The public modules under every stage: any stage may import them, they import no stage."""

_INNER_LISTS = {"planning": ("planning.constraints",)}
"""Subpackages of a stage with a public ``__all__`` of their own."""

PUBLIC_LISTS = (
    "errors",
    *(face for stage in STAGES if stage != "cli" for face in (stage, *_INNER_LISTS.get(stage, ()))),
    "typing",
)
"""The modules (``pincal.<name>``) with a public ``__all__``, in the data flow's order (errors first:
every stage raises them; the command line has none): where a name is looked up, so that finding it
imports little its value does not need."""
