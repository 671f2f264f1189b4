"""aamcore.expression.spec: feature settings and the pipeline spec, checked and round-tripped."""

from __future__ import annotations

import numpy as np
import pytest

from aamcore.expression.spec import (
    FEATURE_VERSION,
    STREAM_REFERENCE,
    FeatureConfig,
    PipelineSpec,
    QualityLimits,
)
from tests.aamcore.expression.synthetic_faces import unit_face


def test_configs_round_trip_through_json_and_bad_ones_are_refused() -> None:
    config = FeatureConfig(blocks=("shape", "hog"), hog_half=8)
    assert FeatureConfig.from_json(config.to_json()) == config
    assert config.with_blocks(("appearance",)).blocks == ("appearance",)
    assert config.with_blocks(("appearance",)).hog_half == 8
    with pytest.raises(ValueError, match="blocks"):
        FeatureConfig(blocks=("hog", "pixels"))
    with pytest.raises(ValueError, match="blocks"):
        FeatureConfig(blocks=("hog", "hog"))
    with pytest.raises(ValueError, match="unknown feature settings"):
        FeatureConfig.from_json({"lbp_grid": [6, 6]})
    with pytest.raises(ValueError, match="multiple"):
        FeatureConfig(hog_half=5, hog_cells=3)


def test_a_spec_round_trips_with_its_template() -> None:
    spec = PipelineSpec(FeatureConfig(), appearance_dim=5, template=unit_face(),
                        quality=QualityLimits(max_yaw_deg=20.0))
    back = PipelineSpec.from_json(spec.to_json(), spec.template)
    assert back.features == spec.features and back.feature_dim == spec.feature_dim == 1972
    assert back.quality == spec.quality and back.reference == STREAM_REFERENCE
    np.testing.assert_array_equal(back.template, unit_face())
    assert back.feature_version == FEATURE_VERSION and back.scheme == "ibug68"
    assert spec.new_reference().min_count == STREAM_REFERENCE["min_count"]
    with pytest.raises(ValueError, match="template is missing"):
        PipelineSpec.from_json(spec.to_json(), None)
    with pytest.raises(ValueError, match="template must be"):
        PipelineSpec(FeatureConfig(), 5, template=np.zeros((51, 2)))
    with pytest.raises(ValueError):
        PipelineSpec(FeatureConfig(), 5, reference={"window": 5, "stride": 1, "min_count": 9})
