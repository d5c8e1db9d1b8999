"""Mitsuba integrators of mitsar: ``radar`` (:mod:`mitsar.plugins.integrators.radar`)."""
