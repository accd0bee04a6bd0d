"""``python -m unicac ARGS...``: the ``unicac`` command (see ``unicac.cli``)."""

import sys

from .cli import main

sys.exit(main())
