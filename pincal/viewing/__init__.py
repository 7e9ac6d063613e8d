"""Seeing a plan: the meshcat scene (:mod:`.scene`), a campaign as an animation
(:mod:`.animation`), its self-contained HTML page (:mod:`.static_page`) and matplotlib plots
(:mod:`.plots`). Optional: the core never imports it, and meshcat and matplotlib are imported when a
scene or a figure is made."""

from pincal.viewing.animation import CampaignScene, campaign_scene
from pincal.viewing.scene import Scene, scene, show

__all__ = ["CampaignScene", "Scene", "campaign_scene", "scene", "show"]
