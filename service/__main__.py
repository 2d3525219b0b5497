"""`python -m service`: run the service (see service.main)."""

import sys

from service.main import main

sys.exit(main())
