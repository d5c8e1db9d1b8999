"""Range-Doppler algorithm (RDA) for dechirped FMCW data (Meta, Hoogeboom & Ligthart 2007).

Steps (docs/design.md §5.6), after the common front end of :mod:`mitsar.focus.spectral`
(RVP removal, azimuth FFT, continuous-motion correction ``H_cm``, azimuth weighting):

1. secondary range compression at the reference range (the bulk of the range-azimuth
   coupling of the 2-D spectrum ``sqrt(k_r^2 - k_x^2)``; exact at the centre of the output
   range span, residual ``(R0 - r_ref)`` times a coefficient that is ~1e-2 rad/m at 15 deg
   squint and vanishes at broadside);
2. range compression with range-cell-migration correction: in the azimuth-frequency bin
   ``f_eta`` a target at closest range ``R0`` sits at ``R0 / D(f_eta)``,
   ``D = sqrt(1 - (lambda f_eta / 2v)^2)``; the range DFT is evaluated directly at
   ``r / D(f_eta)`` for every output range ``r`` by a chirp-z transform per Doppler bin, so the
   RCMC needs no interpolator;
3. azimuth matched filter ``exp(-j k_c D(f_eta) r)`` (the conjugate of the azimuth phase;
   our dechirped data carry ``exp(+j k_r R)``), amplitude ``1/sqrt(r)``;
4. azimuth inverse transform evaluated on the output along-track axis (chirp-z).
"""

from __future__ import annotations

import numpy as np

from mitsar.focus.spectral import Spectrum, evaluate_dtft, secondary_range_compression


def focus_rda(spectrum: Spectrum, *, src: bool = True) -> tuple[np.ndarray, dict]:
    """Form the image from the front-end spectrum (module docstring).

    Parameters
    ----------
    spectrum : Spectrum
        From :func:`mitsar.focus.spectral.prepare_spectrum`.
    src : bool
        Apply the bulk secondary range compression.

    Returns
    -------
    image : ndarray, shape (len(azimuth), len(slant_range))
    processing : dict
        Extra attributes for the image product.
    """
    data = spectrum.data
    if src:
        data = data * secondary_range_compression(spectrum)
    d = spectrum.cosine_factor()
    r = spectrum.slant_range
    dk = spectrum.sample_wavenumber_step
    first = spectrum.k_r[0] - spectrum.k_c
    # sum_n S exp(-j (k_r[n] - k_c) r / D): per-row scale dk / D (RCMC by chirp-z).
    compressed = evaluate_dtft(data, dk / d, r)
    compressed *= np.exp(-1j * first * r[None, :] / d[:, None])
    compressed *= np.exp(-1j * spectrum.k_c * d[:, None] * r[None, :])
    return spectrum.finish(compressed), {"rda_src": int(src),
                                         "reference_range": spectrum.reference_range}
