"""The error every decoder raises, and the size limits of the contract.

A receiver checks each limit before it allocates anything, so a hostile or
broken payload costs at most a bounded amount of memory and time.
"""

from __future__ import annotations


class ProtoError(ValueError):
    """A message does not fit the contract.

    Parameters
    ----------
    reason : str
        What is wrong, naming the field (``"fit.landmarks: ..."``); never empty.
    """

    def __init__(self, reason: str) -> None:
        if not reason:
            raise ValueError("ProtoError needs a non-empty reason")
        super().__init__(reason)
        self.reason = reason


MAX_IMAGE_WIDTH = 4096
MAX_IMAGE_HEIGHT = 4096
MAX_IMAGE_PIXELS = 4096 * 2160
"""A 4K (DCI 4096 x 2160) image; either side may be up to 4096."""
MAX_IMAGE_BYTES = MAX_IMAGE_PIXELS * 3
"""A raw 4K image with 3 channels; also the limit of a JPEG image."""

MAX_DIM = 4096
"""Largest length of any array dimension (images included)."""
MAX_SMALL_ARRAY_BYTES = 256 * 1024
"""Largest array in a message other than an image."""
MAX_STR_LEN = 1024
"""Longest string field, in bytes of UTF-8 (per element for string lists)."""
MAX_LIST_LEN = 256
"""Longest list field (e.g. ``Expression.class_names``)."""
MAX_INT = 2**63 - 1
"""Integers are int64 on the wire so that every language can hold them."""

MAX_IMAGE_PAYLOAD = MAX_IMAGE_BYTES + 64 * 1024
"""Largest encoded ``frame`` or ``overlay`` message."""
MAX_SMALL_PAYLOAD = 1024 * 1024
"""Largest encoded message of any other kind."""
MAX_MAP_LEN = 32
"""Most entries of any msgpack map in a valid message."""
