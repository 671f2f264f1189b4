"""Zenoh key expressions of the aamtrack bus.

Every key lives under ``aamtrack/<stream>/``:

==============================================  ===========================================
key                                             what
==============================================  ===========================================
``aamtrack/<stream>/frame``                     captured frames (``Frame``)
``aamtrack/<stream>/boxes``                     face detections (``FaceBoxes``)
``aamtrack/<stream>/fit``                       AAM fits (``Fit``)
``aamtrack/<stream>/pose``                      head poses (``HeadPose``)
``aamtrack/<stream>/expression``                expressions (``Expression``)
``aamtrack/<stream>/overlay``                   rendered overlays (``Overlay``)
``aamtrack/<stream>/eos``                       end of stream (``EndOfStream``)
``aamtrack/<stream>/status/<service>``          service health (``Status``)
``aamtrack/<stream>/detect``                    the detector's queryable (``Frame`` in,
                                                ``FaceBoxes`` out)
``aamtrack/<stream>/alive/<service>``           liveliness token of a running service
``aamtrack/<stream>/keys``                      the launcher's queryable: the run's public
                                                keys, signed by its own (``proto.auth``)
==============================================  ===========================================

Stream ids and service names are single key chunks from a safe alphabet, so
they can never inject ``/``, ``*``, ``$``, ``#``, ``?`` or ``@`` into a key.
"""

from __future__ import annotations

import re

from proto.limits import ProtoError

ROOT = "aamtrack"
TOPICS = ("frame", "boxes", "fit", "pose", "expression", "overlay", "eos")
"""Message kinds published on ``aamtrack/<stream>/<kind>``."""
STATUS = "status"
DETECT = "detect"
ALIVE = "alive"
KEYS = "keys"
OWNERS: dict[str, str] = {
    "frame": "source",
    "eos": "source",
    "boxes": "detector",
    "fit": "fitter",
    "pose": "pose",
    "expression": "expression",
    "overlay": "ar",
}
"""The service that owns each topic: the only producer whose messages on it count."""

IMAGES = ("frame", "overlay")
"""Topics of images: large, replaced many times a second, droppable."""
RESULTS = ("boxes", "fit", "pose", "expression")
"""Topics of per-frame results: small and wanted at once."""

NAME_MAX_LEN = 64
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def check_name(name: object, what: str = "stream id") -> str:
    """Validate a stream id or service name and return it.

    A name is 1 to 64 characters of ``A-Z a-z 0-9 _ . -`` that does not
    start with ``.`` or ``-``.

    Raises
    ------
    ProtoError
        Naming ``what`` and the offending value.
    """
    if not isinstance(name, str):
        raise ProtoError(f"{what}: expected a string, got {type(name).__name__}")
    if not 1 <= len(name) <= NAME_MAX_LEN or _NAME.fullmatch(name) is None:
        raise ProtoError(
            f"{what}: {name[:80]!r} is not 1 to {NAME_MAX_LEN} characters of "
            "A-Z a-z 0-9 _ . - (not starting with . or -)"
        )
    return name


def topic_key(stream: str, kind: str) -> str:
    """Key of a per-stream message kind, e.g. ``aamtrack/cam0/fit``."""
    if kind not in TOPICS:
        raise ProtoError(f"kind {kind!r} has no per-stream key; topics are {list(TOPICS)}")
    return f"{ROOT}/{check_name(stream)}/{kind}"


def status_key(stream: str, service: str) -> str:
    """``aamtrack/<stream>/status/<service>``."""
    return f"{ROOT}/{check_name(stream)}/{STATUS}/{check_name(service, 'service')}"


def detect_key(stream: str) -> str:
    """``aamtrack/<stream>/detect``: the detector's queryable."""
    return f"{ROOT}/{check_name(stream)}/{DETECT}"


def alive_key(stream: str, service: str) -> str:
    """``aamtrack/<stream>/alive/<service>``: a service's liveliness token."""
    return f"{ROOT}/{check_name(stream)}/{ALIVE}/{check_name(service, 'service')}"


def keys_key(stream: str) -> str:
    """``aamtrack/<stream>/keys``: the launcher's queryable of the run's public keys."""
    return f"{ROOT}/{check_name(stream)}/{KEYS}"


def stream_wildcard(stream: str) -> str:
    """``aamtrack/<stream>/**``: everything of one stream."""
    return f"{ROOT}/{check_name(stream)}/**"


def status_wildcard(stream: str = "*") -> str:
    """``aamtrack/<stream>/status/*``; the default ``*`` matches every stream."""
    chunk = stream if stream == "*" else check_name(stream)
    return f"{ROOT}/{chunk}/{STATUS}/*"


def alive_wildcard(stream: str = "*") -> str:
    """``aamtrack/<stream>/alive/*``; the default ``*`` matches every stream."""
    chunk = stream if stream == "*" else check_name(stream)
    return f"{ROOT}/{chunk}/{ALIVE}/*"


def topic_wildcard(kind: str) -> str:
    """``aamtrack/*/<kind>``: one message kind of every stream."""
    if kind not in TOPICS:
        raise ProtoError(f"kind {kind!r} has no per-stream key; topics are {list(TOPICS)}")
    return f"{ROOT}/*/{kind}"


def owner_of(key: str) -> str | None:
    """The producer that owns a concrete key (``status/<service>``: that service), or None."""
    try:
        _, topic, service = parse_key(key)
    except ProtoError:
        return None
    return service if topic == STATUS else OWNERS.get(topic)


def parse_key(key: str) -> tuple[str, str, str | None]:
    """Split a concrete aamtrack key into ``(stream, topic, service)``.

    ``topic`` is a message kind, ``"status"``, ``"detect"``, ``"keys"`` or ``"alive"``;
    ``service`` is set for status and alive keys and ``None`` otherwise.

    Raises
    ------
    ProtoError
        When ``key`` is not one of the keys this module builds.
    """
    parts = str(key).split("/")
    if len(parts) in (3, 4) and parts[0] == ROOT:
        stream, topic = check_name(parts[1]), parts[2]
        if len(parts) == 3 and (topic in TOPICS or topic in (DETECT, KEYS)):
            return stream, topic, None
        if len(parts) == 4 and topic in (STATUS, ALIVE):
            return stream, topic, check_name(parts[3], "service")
    raise ProtoError(f"{str(key)[:200]!r} is not an aamtrack key")
