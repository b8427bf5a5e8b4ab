"""Benchmarks behind `rapidc bench TARGET`, one module per target."""
