"""The bundled example experiments: TOML files and scripts, installed as ``mitsar._examples``
(docs/experiments.md). Find them with :func:`mitsar.experiment.example_path` and
:func:`mitsar.experiment.examples_dir`; this file only makes the folder a package that
``importlib.resources`` can find, in a checkout and in an installed wheel alike."""
