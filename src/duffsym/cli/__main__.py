"""``python -m duffsym.cli ...``: the ``duffsym`` command."""

import sys

from duffsym.cli import main

sys.exit(main())
