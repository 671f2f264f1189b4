"""Errors raised by the pose package."""

from __future__ import annotations


class PoseError(ValueError):
    """The input to a pose estimate is unusable; the message says why."""


class IntrinsicsError(ValueError):
    """Camera intrinsics are missing, malformed or implausible; the message names the source."""
