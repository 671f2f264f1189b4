"""The aamtrack message contract: msgpack messages and Zenoh key expressions.

``proto/README.md`` is the specification; this package implements it::

    from proto import Fit, Header, decode, encode
    payload = encode(fit)               # bytes to publish on fit.key()
    msg = decode(payload, "fit")        # raises ProtoError on anything invalid

The package knows the bus (keys, ``zenoh_config``) but nothing of the algorithms.
"""

from proto.codec import decode, encode
from proto.header import SCHEMA_VERSION, Header
from proto.limits import ProtoError
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
