"""Products that describe themselves: every product's schema, maker and validator.

One module a product, each with its layout (dims, coordinates, variables with CF ``units`` and
``long_name``, required attributes), a ``make_*`` constructor and a ``validate_*`` that names
what is missing (docs/products.md):

* :mod:`~mitsar.products.histogram` — complex range histograms of a traced acquisition;
* :mod:`~mitsar.products.raw` — dechirped FMCW samples with their track, and the accessors
  (:func:`~mitsar.products.raw.radar_of`, :func:`~mitsar.products.raw.look_of`,
  :func:`~mitsar.products.raw.track_geometry`);
* :mod:`~mitsar.products.image` — focused pixels on a grid, with coverage (a ``channel`` dim
  for a multi-channel radar);
* :mod:`~mitsar.products.interferogram` — a channel pair's phase, coherence, heights and
  their predicted noise (:func:`mitsar.interferometry.interferogram`);
* :mod:`~mitsar.products.requests` — what a run asks of its later stages (focus options,
  metrics target, ISLR extent, targets, scene), written into the raw product when it is made
  and carried into the image, so no later stage parses the experiment again;
* :mod:`~mitsar.products.schema` — what a schema is, the one validator, and the optional
  ``channel`` and ``pass`` dimensions the multi-channel and repeat-pass products will add.

The package sits between ``model`` and ``raw`` (docs/design.md §2): producers (``raw``) and
consumers (``focus``, ``quality``, ``plots``, ``experiment``, ``cli``) import it.
"""
