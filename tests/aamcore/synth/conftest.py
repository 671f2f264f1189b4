"""A texture shared by the synth tests (built once)."""

from __future__ import annotations

import pytest

from aamcore.synth.head import synth_head
from aamcore.synth.sequence import default_texture
from aamcore.synth.texture import FaceTexture


@pytest.fixture(scope="session")
def texture() -> FaceTexture:
    return default_texture(synth_head())
