"""``python -m depixel``: the same as the ``depixel`` command (the front end lives in depixel_cli)."""
import sys

from depixel_cli.main import main

sys.exit(main())
