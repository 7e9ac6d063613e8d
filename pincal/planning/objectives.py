"""The criteria a design minimises, by name, and the test poses a design is checked against.

The criteria themselves (their values, gradients and exchange updates) are the objects of
:mod:`pincal.evaluation.registry`, one file each under ``pincal/evaluation/``; the searches use
them through the :class:`~pincal.evaluation.criterion.Criterion` interface only.
"""

from __future__ import annotations

import numpy as np

from pincal.errors import BadArgument
from pincal.evaluation.region import resolve_test_poses
from pincal.evaluation.registry import (
    CRITERIA,
    TEST_POSE_CRITERIA,
    criterion_name,
)
from pincal.model.parameters import ParameterSet
from pincal.typing import TestPoseLike

__all__ = [
    "CRITERIA",
    "TEST_POSE_CRITERIA",
    "checked_test_poses",
    "criterion_name",
]


def checked_test_poses(
    params: ParameterSet, test_pose: TestPoseLike | None, criterion: str
) -> np.ndarray | None:
    """The (k, nq) test poses of a design (a region's or path's sample configurations), checked
    against the robot; None if none is given and the criterion needs none.

    Raises:
        PincalError: the criterion needs a test pose and none is given.
        BadConfiguration: a test pose of the wrong shape or outside the joint limits.
    """
    if test_pose is None:
        if criterion in TEST_POSE_CRITERIA:
            raise BadArgument(f"criterion {criterion!r} needs a test pose (test_pose=...)")
        return None
    return resolve_test_poses(params.robot, test_pose)[0]
