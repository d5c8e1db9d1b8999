"""mitsar's library of Mitsuba XML scenes and their meshes, installed as the data package
``mitsar._scenes``. Open, copy and edit the XML files here; load them by name with
``mitsar.scene.load_scene("control_volume")`` (names: ``mitsar.scene.canned.names()``; what each
holds: :mod:`mitsar.scene.canned` and docs/scenes.md). This file only makes the folder a package
that ``importlib.resources`` finds, in a checkout and in an installed wheel alike."""
