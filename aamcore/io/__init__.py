"""Readers for annotated face datasets.

- :func:`read_asf`: AAM-API ``.asf`` shape files (IMM Frontal, 73 points).
- :func:`read_pts`: 300-W ``.pts`` files (LFPW, 68 points).
- :func:`load_jaffe`: the JAFFE expression set (poser and class from names).
- :func:`load_annotated_folder`: every annotated image of a folder as
  :class:`FaceSample` objects, with the files that could not be read listed
  apart rather than stopping the load.
"""

from aamcore.io.asf import AsfShape, read_asf
from aamcore.io.folder import AnnotatedSet, load_annotated_folder
from aamcore.io.jaffe import ExpressionSample, JaffeSet, load_jaffe
from aamcore.io.pts import read_pts
from aamcore.io.sample import DatasetError, FaceSample, read_image

__all__ = [
    "AnnotatedSet",
    "AsfShape",
    "DatasetError",
    "ExpressionSample",
    "FaceSample",
    "JaffeSet",
    "load_annotated_folder",
    "load_jaffe",
    "read_asf",
    "read_image",
    "read_pts",
]
