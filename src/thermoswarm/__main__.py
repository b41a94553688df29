"""``python -m thermoswarm`` is the same as the ``thermoswarm`` command."""

from thermoswarm.cli import main

if __name__ == "__main__":
    main()
