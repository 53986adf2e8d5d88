"""`python -m platoon.sumo`: the SUMO plant process (platoon.sumo.plant)."""

import sys

from platoon.sumo.plant import main

sys.exit(main())
