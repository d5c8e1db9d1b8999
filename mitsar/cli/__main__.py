"""``python -m mitsar.cli``: the ``mitsar`` command."""

import sys

from mitsar.cli import main

sys.exit(main())
