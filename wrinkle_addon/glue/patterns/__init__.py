"""Glue of the pattern functions and tears: pattern layers (layers), the dripping tear
(tears), shedding tears (shedding)."""
