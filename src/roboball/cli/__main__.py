"""`python -m roboball.cli`: the `roboball` command."""
import sys

from roboball.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
