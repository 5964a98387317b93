"""``python -m doodle`` runs the command line, like ``doodle``."""

from .cli import main

if __name__ == "__main__":
    main()
