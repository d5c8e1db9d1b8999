"""Figures (matplotlib, Agg backend): products and metrics (:mod:`~mitsar.plots.figures`),
ray geometry and multipath echoes (:mod:`~mitsar.plots.rays`).

Importing this package does not import matplotlib; its modules do.
"""
