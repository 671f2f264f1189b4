"""Named pipelines: the default stack and the thesis's own, each a preset of the options tree.

A :class:`Profile` is a named :class:`~aamcore.operators.options.PipelineOptions`: how the
fitting model's update matrices are learned, the fitting, the head-pose estimator and the
expression features are values of it. ``aamtrack model prepare --profile NAME`` trains
what it needs, ``aamtrack run --profile NAME`` and ``FaceTracker(profile=NAME)`` run it;
options given beside a profile go over its values.

- ``default``: the local-binary landmark regressor with its learned quality
  test, the AAM's appearance and occlusion flags on every good fit, the
  contour head-pose estimator, HOG + shape expression features.
- ``thesis``: the thesis's pipeline (chapters 6, 7, 9 and 14): the AAM fitted
  by the fixed-Jacobian update (Algorithm 7, eq. 7.1; ``aamtrack train
  --update regression`` gives a model with the regression update of
  Algorithm 5 instead), the failure test of eq. 7.2, POSIT on a statistical
  anthropometric head (the OpenFace mean 68-point head, the closest to the
  thesis's laser-scanned model that can be had; the jaw left out, as measured
  in ``bench/bench_posit.py``), and LDA + Mahalanobis on the appearance ``c``.

:func:`model_path` and :func:`classifier_path` are the one door from running code to
training: a model or classifier the options do not name is trained and cached on first use.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from aamcore.operators.options import PIPELINE, ModelOptions, PipelineOptions


@dataclass(frozen=True)
class Profile:
    """One pipeline: a name, a line, and its options.

    Attributes
    ----------
    name : str
    summary : str
    options : PipelineOptions
    """

    name: str
    summary: str
    options: PipelineOptions


PROFILES: dict[str, Profile] = {
    p.name: p
    for p in (
        Profile("default", "local-binary landmarks, the AAM's appearance and occlusion flags, "
                "contour head pose, HOG + shape expression", PIPELINE),
        Profile("thesis", "the thesis: fixed-Jacobian AAM fitting, eq. 7.2 failure test, "
                "POSIT on the anthropometric mean head, LDA + Mahalanobis on c",
                PIPELINE.with_values(algorithm="fixed-jacobian", failure_test="eq7.2",
                                     pose_estimator="posit", expression_features="thesis")),
    )
}
"""Profile name -> :class:`Profile`."""


def profile_named(name: str) -> Profile:
    """The profile called ``name``.

    Raises
    ------
    ValueError
        For an unknown name.
    """
    if name not in PROFILES:
        raise ValueError(f"unknown profile {name!r}: choose one of {list(PROFILES)}")
    return PROFILES[name]


def model_path(model: ModelOptions = PIPELINE.model) -> Path:
    """The fitting model's file: the one named, or the default recipe with the update method
    asked for, trained and cached on first use."""
    if model.file:
        return Path(model.file)
    from aamcore.fitting.training.prepare import default_model_path

    return default_model_path(max_images=model.images, limit=model.limit or None,
                              update_method=model.update)


def classifier_path(model: str | Path, options: PipelineOptions = PIPELINE) -> Path:
    """The expression classifier of ``options`` for the fits of the model file ``model``:
    the one named, or the one of its features for the model and the fitting algorithm,
    trained and cached on first use.

    Raises
    ------
    aamcore.io.sample.DatasetError
        When an expression set is missing or unreadable, or no face can be classified.
    """
    if options.expression.classifier:
        return Path(options.expression.classifier)
    from aamcore.expression.training import classifier_path as trained

    return trained(model, options.fit.fitting.algorithm, options.expression.features)
