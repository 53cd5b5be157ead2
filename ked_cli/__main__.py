"""``python -m ked_cli``: the ``ked`` command."""

from ked_cli.main import main

main()
