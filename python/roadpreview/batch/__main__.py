# SPDX-License-Identifier: BSD-3-Clause
"""``python -m roadpreview.batch``: the ``roadpreview batch`` command."""

import sys

from .cli import main

sys.exit(main())
