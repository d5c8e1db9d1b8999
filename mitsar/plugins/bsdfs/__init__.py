"""Mitsuba BSDFs of mitsar: ``doublelobe`` (radar material) and ``pointtarget``."""
