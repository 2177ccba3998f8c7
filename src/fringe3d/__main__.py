"""``python -m fringe3d``: the same as the ``fringe3d`` command."""
import sys

from fringe3d.cli import main

sys.exit(main())
