"""Shared fixtures for the trajectory tests."""

from __future__ import annotations

import pytest
from traj_helpers import PAYLOAD_SCENE

from trajectory import Scene, load_scene, parse_scene
from trajectory.scene import EXAMPLE_SCENE


@pytest.fixture(scope="session")
def example_scene() -> Scene:
    return parse_scene(EXAMPLE_SCENE, "example.toml")


@pytest.fixture(scope="session")
def payload_scene() -> Scene:
    return load_scene(PAYLOAD_SCENE)
