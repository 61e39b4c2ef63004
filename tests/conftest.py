"""Test configuration: studies marked ``slow`` run only with OPTINAV_FULL=1 (CI runs their quick versions)."""

import os

import pytest


def pytest_collection_modifyitems(config, items):
    if os.environ.get("OPTINAV_FULL"):
        return
    skip = pytest.mark.skip(reason="slow study: set OPTINAV_FULL=1 to run the full version")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
