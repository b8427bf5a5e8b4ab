"""Seeded scene variants: the ranges they are drawn from, the sampler, the solid geometry it places
objects with, and the check that a variant still builds."""
