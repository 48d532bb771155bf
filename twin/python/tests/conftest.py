"""What the tests share: the twin command line they check the package against."""

import os
from pathlib import Path

import pytest


@pytest.fixture
def twin_cli():
    """The twin command line of the same checkout (scripts/test sets TWIN)."""
    path = os.environ.get("TWIN")
    if not path:
        pytest.fail("set TWIN to the twin command line, e.g. target/release/twin (scripts/test does)")
    # Absolute, since tests run it from their own temporary folders.
    return str(Path(path).resolve())
