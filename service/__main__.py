"""`python -m service`: run the service (see service.main)."""

import sys

from .main import main

sys.exit(main())
