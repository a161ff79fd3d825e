import sys

from .cli import main

# Guarded: a worker process started with "spawn" imports this module without running it.
if __name__ == "__main__":
    sys.exit(main())
