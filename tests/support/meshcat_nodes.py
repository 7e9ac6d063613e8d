"""Reading a built meshcat scene (pincal.viewing.scene) back: its nodes and their transforms.
Shared by tests/viewing/test_visualize.py and tests/campaign/test_campaign.py."""

from __future__ import annotations

import importlib

import numpy as np
import umsgpack

visualize = importlib.import_module("pincal.viewing.scene")  # the module (pincal.viewing.scene: the function)


def node(built, path):
    return built.viewer.window.node(f"/meshcat/{visualize.ROOT}/{path}")


def unpack(payload):
    return umsgpack.unpackb(payload)


def matrix(node_):
    """The 4×4 transform of a scene node (meshcat sends it column-major)."""
    return np.array(unpack(node_.transform)["matrix"]).reshape(4, 4).T
