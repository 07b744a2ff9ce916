"""``python -m feedtune``: the same command line as the ``feedtune`` script."""

from feedtune.cli import main

if __name__ == "__main__":
    main(prog_name="feedtune")
