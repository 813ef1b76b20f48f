"""``python -m ksbo_sim.mavlink [options]``: run the MAVLink vehicle simulator (same as ``ksbo-mav sim``)."""

import sys

from ksbo_sim.mavlink.options import main

sys.exit(main())
