"""Pure physics, written once for NumPy and Dr.Jit alike (``docs/design.md`` §2-§5).

``radar`` (paper Table 1), ``signal`` (the dechirped signal model, radar equation), ``targets``
(point targets, background of paper eq. 4), ``geometry`` (trajectory, attitude, antenna),
``doublelobe`` (the material model, paper eqs. 8-12), ``histogram`` (the deposit of §5.5) and
``multipath`` (ray-tube bookkeeping). Nothing here needs Mitsuba.
"""
