"""``python -m depixel``: the same as the ``depixel`` command (the front end lives in depixel_cli)."""
from depixel_cli.entry import main

main()
