import numpy as np

from aamcore.expression.aam_features import AAMAppearanceFeatures, fit_faces
from aamcore.expression.evaluation import default_classifiers, leave_one_poser_out
from aamcore.fitting.fitter import Fitter
from aamcore.fitting.model import FittingModel


def test_fitted_faces_and_per_fold_appearance(jaffe_set, lfpw_fit_model_path) -> None:
    fitter = Fitter(FittingModel.load(lfpw_fit_model_path), appearance=True)
    chosen = [s for s in jaffe_set.samples if s.poser in ("KA", "KL", "KM")]
    faces = fit_faces(chosen, fitter)
    assert len(faces.samples) + len(faces.errors) == len(chosen)
    assert len(faces.samples) >= 0.7 * len(chosen)
    assert all(".tiff" in e for e in faces.errors)
    points = np.stack([f.points for f in faces.samples])
    # Landmarks land on the 256x256 faces, eyes above the mouth.
    assert np.all((points > 0) & (points < 256))
    assert np.all(points[:, 36:48, 1].mean(axis=1) < points[:, 48:68, 1].mean(axis=1))

    posers = np.array([f.subject for f in faces.samples])
    train = [f for f in faces.samples if f.subject != "KA"]
    test = [f for f in faces.samples if f.subject == "KA"]
    transform = AAMAppearanceFeatures(fitter.aam.scheme, 0.95, n_pixels=3000).fit(train)
    c = transform(test)
    assert c.shape[0] == len(test) and np.all(np.isfinite(c))

    labels = np.array([chosen[i].label for i in faces.kept])
    results = leave_one_poser_out(
        faces.samples,
        labels,
        posers,
        AAMAppearanceFeatures(fitter.aam.scheme, 0.95, 3000),
        default_classifiers(n_trials=3)[:1],
    )
    assert results[0].overall_rate > 2.0 / 7  # chance is 1/7
