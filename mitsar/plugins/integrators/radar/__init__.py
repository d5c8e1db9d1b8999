"""The ``radar`` integrator: an FMCW SAR acquisition traced into range histograms, by stage.

What it computes (docs/design.md §5.4–5.5; docs/integrator.md, docs/multipath.md): a fixed set of
surface scatterers and the scene's point targets (:mod:`mitsar.model.scatterers`) are traced
against every sweep of an acquisition in one vectorised wavefront, in chunks of up to 128
sweeps: static scenes one lane per scatterer and chunk (the block kernel), the others one lane
per (scatterer, sweep) pair; multipath rays are shot and bounced per sweep of the same chunks.
Every contribution is deposited into a complex range histogram at its apparent range;
:func:`mitsar.model.histogram.histogram_to_raw` then gives the raw sweeps by one inverse FFT
each.

==================== =================================================================== ======
module               stage                                                               Mitsuba
==================== =================================================================== ======
:mod:`.config`       XML name and parameters (TraceOptions' fields), launch sizes         no
:mod:`.setup`        per-acquisition ray frames, 2D plane, bistatic receiver, ray grid   no
:mod:`.constants`    packed launch constants and per-sweep / per-scatterer device arrays yes
:mod:`.deposit`      the one deposit of every mechanism into the histogram               yes
:mod:`.backscatter`  mechanism 1: candidates, cull, trace (staged kernels), probes        yes
:mod:`.blocks`       mechanism 1's block kernel: a lane per scatterer and sweep block    yes
:mod:`.bounce`       mechanism 2: shooting and bouncing rays, capture, ghosts            yes
:mod:`.integrator`   the Mitsuba plugin class and ``register()``                         yes
==================== =================================================================== ======

This package imports only the modules without Mitsuba, so a configuration can be built and
checked before a variant is chosen; :mod:`mitsar.plugins.variant` imports :mod:`.integrator` once
a variant is set.
"""

from mitsar.plugins.integrators.radar.config import PARAMETERS, PLUGIN_NAME
from mitsar.plugins.integrators.radar.setup import TraceSetup, make_setup

__all__ = ["PARAMETERS", "PLUGIN_NAME", "TraceSetup", "make_setup"]
