"""`python -m vehil` is the `vehil` command."""

import sys

from vehil.cli import main

sys.exit(main())
