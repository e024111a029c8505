"""Fuzz suite fixtures: the inputs tried per reader are written out at the end of each module."""

from __future__ import annotations

import pytest

from fuzzing import record_counts


@pytest.fixture(scope="module", autouse=True)
def _report_counts():
    yield
    record_counts()
