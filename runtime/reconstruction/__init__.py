"""Scenes from RGB-D frames: reading and rendering frames, and reconstructing supports and objects
from depth and masks."""
