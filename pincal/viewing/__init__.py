"""Seeing a plan: the meshcat scene (:mod:`.scene`), its self-contained HTML page
(:mod:`.static_page`) and matplotlib plots (:mod:`.plots`). Optional: the core never imports it."""
