"""``python -m sideslip``: see :mod:`sideslip.cosim.cli`."""
import sys

from sideslip.cosim.cli import main

sys.exit(main())
