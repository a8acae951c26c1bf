"""``python -m pipeline.report <sweep, run or dataset dir> [--out FILE]``."""

import sys

from pipeline.report.html import main

sys.exit(main())
