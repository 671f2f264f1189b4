"""aamcore.expression.faces: labelled faces fitted as the stack fits a stream's first frame,
kept as arrays, read again when asked; a file that cannot be read is named, skipped and
counted."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from aamcore.expression.faces import LabelledFaces, fit_faces, stack_observations
from aamcore.expression.labels import SEVEN_CLASSES
from aamcore.expression.quality import landmark_problem
from aamcore.fitting.model import FittingModel
from aamcore.io.expression_sets import ExpressionSet, load_expression_set
from aamcore.io.jaffe import ExpressionSample
from aamcore.io.sample import DatasetError


def test_every_jaffe_face_is_observed_as_the_stack_fits_it(jaffe: LabelledFaces) -> None:
    assert len(jaffe.observations) == len(jaffe.labels) == len(jaffe.posers) == 213
    assert not jaffe.no_face.any()  # Haar finds every JAFFE face
    obs = jaffe.observations[0]
    assert obs.landmarks.shape == (68, 2) and obs.image.shape == (256, 256)
    np.testing.assert_array_equal(obs.landmarks, obs.landmarks.astype(np.float32))
    assert set(jaffe.labels) == set(SEVEN_CLASSES) and len(set(jaffe.posers)) == 10
    assert jaffe.names[0].endswith(".tiff") and set(jaffe.sets) == {"jaffe"}


def test_an_image_without_a_face_is_observed_as_no_face(model_path: Path) -> None:
    (obs,) = stack_observations(FittingModel.load(model_path), [np.full((240, 320), 90,
                                                                        np.uint8)])
    assert obs.landmarks.shape == (0, 2) and obs.fit_failed and obs.fit_reason == "no face"


def test_fits_are_kept_without_images_and_read_again(model_path: Path, data_dir: Path,
                                                     tmp_path: Path) -> None:
    data = load_expression_set("taiwan_expressions", data_dir / "taiwan_expressions")
    chosen = np.zeros(len(data.samples), bool)
    chosen[:6] = True
    model = FittingModel.load(model_path)
    one = fit_faces(model, data, select=chosen, workers=1)
    two = fit_faces(model, data, select=chosen, workers=2)
    np.testing.assert_array_equal(one.landmarks, two.landmarks)  # threads change nothing
    assert one.images is None and one.observation(3).image.shape == (256, 256, 3)
    one.save(tmp_path / "faces.npz")
    back = LabelledFaces.load(tmp_path / "faces.npz")
    assert back is not None and list(back.names) == list(one.names)
    np.testing.assert_array_equal(back.landmarks, one.landmarks)
    both = LabelledFaces.concatenate([one, back.subset(np.array([0, 5]))])
    assert len(both.labels) == 8 and both.paths[7] == one.paths[5]


def test_an_unreadable_image_is_named_skipped_and_counted(
    model_path: Path, data_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    good = tmp_path / "0111b01.jpg"
    shutil.copy(data_dir / "taiwan_expressions" / "0111b01.jpg", good)
    broken = tmp_path / "0111b02.jpg"
    broken.write_bytes(b"not a jpeg")
    missing = tmp_path / "0111b03.jpg"
    data = ExpressionSet("taiwan_expressions", [ExpressionSample(good, "01", "HA", 1, 1),
                                                ExpressionSample(broken, "01", "HA", 1, 2),
                                                ExpressionSample(missing, "01", "HA", 1, 3)],
                         tmp_path)
    for keep in (False, True):
        faces = fit_faces(FittingModel.load(model_path), data, keep_images=keep)
        assert faces.no_face.tolist() == [False, True, True]
        assert faces.reasons[1] == f"unreadable image: {broken}: not a readable image"
        assert faces.reasons[2] == f"unreadable image: {missing}: image file not found"
        why = [landmark_problem(faces.observation(i)) for i in range(3)]
        assert why[0] == "" and why[1] == f"no face: {faces.reasons[1]}"
        assert (faces.images is not None) == keep
        if keep:
            assert len(faces.images) == 3 and faces.images[0].shape == (256, 256, 3)
        said = capsys.readouterr().err
        assert (f"taiwan_expressions: 2 of 3 image files skipped, unreadable (the first: "
                f"{broken}: not a readable image)") in said
    with pytest.raises(DatasetError, match="no face of taiwan_expressions"):
        fit_faces(FittingModel.load(model_path), data, select=np.zeros(3, bool))
