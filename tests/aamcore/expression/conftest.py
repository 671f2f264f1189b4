"""Real JAFFE data shared by the expression tests: images, face crops, labels, posers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aamcore.expression.benchmark import PixelData, load_pixel_data

FIVE_POSERS = ["KA", "KL", "KM", "KR", "MK"]


@pytest.fixture(scope="session")
def jaffe_pixels(jaffe_dir: Path) -> PixelData:
    """Face-crop pixels (213, 2304) of every JAFFE image, with labels and posers."""
    data = load_pixel_data(jaffe_dir)
    assert not data.skipped, data.skipped
    return data


@pytest.fixture(scope="session")
def five_posers(jaffe_pixels: PixelData) -> PixelData:
    """The samples of five posers (about 105)."""
    return jaffe_pixels.subset(np.isin(jaffe_pixels.posers, FIVE_POSERS))
