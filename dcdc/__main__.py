"""``python -m dcdc``: the ``dcdc`` command line."""
from .cli import main

if __name__ == "__main__":
    main()
