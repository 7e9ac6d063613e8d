"""Optional dependencies (meshcat, matplotlib), imported only when a function needs them."""

from __future__ import annotations

import importlib
import warnings
from types import ModuleType

from pincal.errors import MissingDependency


def require(module: str, feature: str, install: str) -> ModuleType:
    """Import ``module`` or raise :class:`MissingDependency` naming ``feature`` and the fix.

    Args:
        module: the module to import, e.g. ``"matplotlib.pyplot"``.
        feature: what needs it, for the message (``"pincal.viewing.plots"``, ``"--plot"``).
        install: the pip requirement that provides it (``"pincal[plot]"``).
    """
    try:
        with warnings.catch_warnings():  # meshcat imports pyzmq's deprecated eventloop module
            warnings.simplefilter("ignore", DeprecationWarning)
            return importlib.import_module(module)
    except ImportError:
        raise MissingDependency(
            f'{feature} needs {module.split(".")[0]}, which is not installed: pip install "{install}"'
        ) from None
