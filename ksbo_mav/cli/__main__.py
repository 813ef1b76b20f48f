import sys

from ksbo_mav.cli import main

sys.exit(main())
