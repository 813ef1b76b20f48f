import sys

from ksbo_bench.cli import main

sys.exit(main())
