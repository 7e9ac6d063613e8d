"""Seeing a plan: the meshcat scene (:mod:`.scene`), its self-contained HTML page
(:mod:`.static_page`) and matplotlib plots (:mod:`.plots`). Optional: the core never imports it,
and meshcat and matplotlib are imported when a scene or a figure is made."""

from pincal.viewing.scene import Scene, scene, show

__all__ = ["Scene", "scene", "show"]
