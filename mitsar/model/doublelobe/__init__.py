"""Double-lobe radar material (paper eqs. 8-11, Degli-Esposti et al. 2007), in small pure functions.

``lobes`` (one lobe: shape, hemisphere integral, tables, sampling, the NumPy ``ops``), ``pattern``
(the two-lobe pattern, σ⁰ laws, Sionna RT convention), ``material`` (the :class:`DoubleLobe`
parameters, presets and the σ⁰ and specular tables of the radar kernel) and ``radio`` (Sionna
RT's radio material: Fresnel reflection of ITU-R P.2040-3 materials + the lobes). Every public
name of the four is re-exported here.
"""

from __future__ import annotations

from mitsar.model.doublelobe import lobes, material, pattern, radio
from mitsar.model.doublelobe.lobes import *  # noqa: F403
from mitsar.model.doublelobe.material import *  # noqa: F403
from mitsar.model.doublelobe.pattern import *  # noqa: F403
from mitsar.model.doublelobe.radio import *  # noqa: F403

__all__ = [*lobes.__all__, *pattern.__all__, *material.__all__, *radio.__all__]
