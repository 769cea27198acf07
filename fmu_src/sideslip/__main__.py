"""``python -m sideslip``: see :mod:`sideslip.cli`."""
import sys

from sideslip.cli import main

sys.exit(main())
