"""``python -m rimroll.study``: the ``study`` console script (``rimroll._command``), the same in every way."""

import sys

from rimroll._command import main

sys.exit(main())
