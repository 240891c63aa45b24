"""The test directory is importable from every test folder (``bt_strategies``, the shared Hypothesis
strategies)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
