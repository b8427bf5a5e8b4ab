"""Demonstrations: tracks of executed or recorded motions, and their analysis into phases and the
primitives that show each phase's effect."""
