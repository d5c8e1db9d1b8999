"""Raw products: the dechirped FMCW samples every producer writes and every focuser reads.

``product`` (the raw-product layout and its radar/geometry accessors), ``analytic`` (point
targets and background, exact per-sample delay, NumPy or Dr.Jit), ``traced`` (Mitsuba ray
tracing through the radar integrator) and ``recorded`` (real recordings: arrays, generic files,
AFRL GOTCHA). Data flow one way: ``raw`` never imports ``mitsar.focus``.
"""
