"""``python -m terrasynth_app``: start the app."""

import sys

from .main import main

sys.exit(main())
