"""What an instrument measures and how well: the measurement kinds (points, poses, partial poses,
distances, images), the instruments' error models and the whitened rows every later stage uses
(docs/method.md §13)."""

from pincal.instruments.camera import Camera
from pincal.instruments.distance import Distance, anchors
from pincal.instruments.error_model import PerCoordinate, Tracker
from pincal.instruments.image import Image, grid
from pincal.instruments.instrument import Instrument
from pincal.instruments.kind import Kind
from pincal.instruments.point import Point
from pincal.instruments.pose import Partial, Pose
from pincal.instruments.rig import Rig, load_rig

__all__ = [
    "Camera",
    "Distance",
    "Image",
    "Instrument",
    "Kind",
    "Partial",
    "PerCoordinate",
    "Point",
    "Pose",
    "Rig",
    "Tracker",
    "anchors",
    "grid",
    "load_rig",
]
