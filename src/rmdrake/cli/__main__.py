"""``python -m rmdrake.cli``: the ``rmdrake`` command."""

from rmdrake.cli.entry import main

if __name__ == "__main__":
    raise SystemExit(main())
