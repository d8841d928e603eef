"""``python -m catpose.bench.regress``: the same as ``bench regress`` (also reachable as
``python -m catpose.bench.regress.run_suites``, which the gate's second-kernel child process uses)."""

import sys

from catpose.bench.regress.run_suites import main

sys.exit(main())
