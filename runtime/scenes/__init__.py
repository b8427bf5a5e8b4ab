"""Scenes: the YAML file's schema and validation, loading, meshes, and the MuJoCo world built
from a scene."""
