"""The aamtrack message contract: msgpack messages and Zenoh key expressions.

``proto/README.md`` is the specification; this package implements it::

    from proto import Fit, Header, decode, encode
    payload = encode(fit)               # bytes to publish on fit.key()
    msg = decode(payload, "fit")        # raises ProtoError on anything invalid

The package knows the bus (keys, ``zenoh_config``) but nothing of the algorithms.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from proto.limits import ProtoError

if TYPE_CHECKING:
    from proto.codec import decode, encode
    from proto.header import SCHEMA_VERSION, Header
    from proto.messages import (
        MESSAGE_TYPES,
        EndOfStream,
        Expression,
        FaceBoxes,
        Fit,
        FitAppearance,
        Frame,
        HeadPose,
        Message,
        Overlay,
        Status,
    )

_HOME = {"decode": "codec", "encode": "codec", "SCHEMA_VERSION": "header", "Header": "header"}
"""Where each name lives (the messages' module for the others): loaded on first use, so that
``import proto.keys`` (the command line's options) imports neither numpy nor msgpack."""

__all__ = [
    "MESSAGE_TYPES",
    "SCHEMA_VERSION",
    "EndOfStream",
    "Expression",
    "FaceBoxes",
    "Fit",
    "FitAppearance",
    "Frame",
    "HeadPose",
    "Header",
    "Message",
    "Overlay",
    "ProtoError",
    "Status",
    "decode",
    "encode",
]


def __getattr__(name: str) -> Any:
    if name not in __all__:
        raise AttributeError(f"module 'proto' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"proto.{_HOME.get(name, 'messages')}"), name)
    globals()[name] = value
    return value
