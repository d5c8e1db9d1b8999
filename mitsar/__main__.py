"""``python -m mitsar``: the ``mitsar`` command (:func:`mitsar.cli.main`)."""

import sys

from mitsar.cli import main

sys.exit(main())
