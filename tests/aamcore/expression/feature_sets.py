"""Real feature matrices of JAFFE for the classifier tests."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass
class FeatureSet:
    """Feature vectors (n, d) of JAFFE faces with their classes and posers (n,)."""

    features: np.ndarray
    labels: np.ndarray
    posers: np.ndarray

    def subset(self, mask: np.ndarray) -> FeatureSet:
        """The samples selected by a boolean mask (n,)."""
        return replace(self, features=self.features[mask], labels=self.labels[mask],
                       posers=self.posers[mask])
