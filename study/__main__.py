"""``python -m rimroll.study``: the same as the ``study`` console script."""

import sys

from rimroll.study.cli import main

sys.exit(main())
