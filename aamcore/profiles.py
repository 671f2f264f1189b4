"""Named pipelines: the default stack and the thesis's own, each a first-class choice.

A :class:`Profile` names everything a pipeline is made of: how the fitting
model's update matrices are learned, the fitting (:class:`~aamcore.fitting.config.FitterConfig`),
the head-pose estimator and the expression features. ``aamtrack model prepare
--profile NAME`` trains what it needs, ``aamtrack run --profile NAME`` and
``FaceTracker(profile=NAME)`` run it; options given beside a profile override
its choices.

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
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from aamcore import defaults
from aamcore.fitting.config import FitterConfig

EXPRESSION_FEATURES = ("deployed", "thesis")
"""Expression feature sets a profile can name (:mod:`aamcore.expression.training`)."""


@dataclass(frozen=True)
class Profile:
    """One pipeline.

    Attributes
    ----------
    name : str
    summary : str
    fitter : FitterConfig
    update_method : {"jacobian", "regression"}
        How the update matrices of the profile's model are learned.
    pose_estimator : str
        One of :data:`aamcore.defaults.POSE_ESTIMATORS`.
    expression : str
        One of :data:`EXPRESSION_FEATURES`.
    """

    name: str
    summary: str
    fitter: FitterConfig
    update_method: str = "jacobian"
    pose_estimator: str = defaults.POSE_ESTIMATOR
    expression: str = "deployed"

    def __post_init__(self) -> None:
        if self.pose_estimator not in defaults.POSE_ESTIMATORS:
            raise ValueError(f"unknown pose estimator {self.pose_estimator!r}")
        if self.expression not in EXPRESSION_FEATURES:
            raise ValueError(f"unknown expression features {self.expression!r}: choose one "
                             f"of {EXPRESSION_FEATURES}")

    def model_path(self, max_images: int = defaults.MODEL_UPDATE_IMAGES,
                   limit: int | None = None, update_method: str | None = None) -> Path:
        """The profile's fitting model: the default recipe with its update method (or
        ``update_method``), trained and cached on first use. The one door from running code
        to training: the library, the services and the commands that run the model ask it
        here."""
        from aamcore.fitting.training.prepare import default_model_path

        return default_model_path(max_images=max_images, limit=limit,
                                  update_method=update_method or self.update_method)

    def classifier_path(self, model_path: str | Path, algorithm: str | None = None) -> Path:
        """The profile's expression classifier for the fits of ``model_path`` by
        ``algorithm`` (the profile's by default), trained and cached on first use.

        Raises
        ------
        aamcore.io.sample.DatasetError
            When an expression set is missing or unreadable, or no face can be classified.
        """
        from aamcore.expression.training import classifier_path

        return classifier_path(model_path, algorithm or self.fitter.algorithm, self.expression)


PROFILES: dict[str, Profile] = {
    p.name: p
    for p in (
        Profile("default", "local-binary landmarks, the AAM's appearance and occlusion flags, "
                "contour head pose, HOG + shape expression", FitterConfig()),
        Profile("thesis", "the thesis: fixed-Jacobian AAM fitting, eq. 7.2 failure test, "
                "POSIT on the anthropometric mean head, LDA + Mahalanobis on c",
                FitterConfig(algorithm="fixed-jacobian", failure_test="eq7.2"),
                pose_estimator="posit", expression="thesis"),
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
