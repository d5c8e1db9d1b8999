"""Image quality: impulse-response metrics (IRW, PSLR, ISLR) of point targets in focused images.

:func:`measure_impulse_response` (:mod:`~mitsar.quality.impulse`) measures a target in an image
product; the 1-D metrics of a cut are in :mod:`~mitsar.quality.cuts`, the band-limited
upsampling they run on in :mod:`~mitsar.quality.upsample`, the image's geometry and the peak
search in :mod:`~mitsar.quality.geometry` and :mod:`~mitsar.quality.peak`.
"""

from mitsar.quality.cuts import ISLR_EXTENTS, first_nulls, irw, islr_db, measure_cut, pslr_db
from mitsar.quality.impulse import measure_impulse_response
from mitsar.quality.upsample import band_fill_db, upsample_chip, upsample_cut

__all__ = [
    "ISLR_EXTENTS", "band_fill_db", "first_nulls", "irw", "islr_db", "measure_cut",
    "measure_impulse_response", "pslr_db", "upsample_chip", "upsample_cut",
]
