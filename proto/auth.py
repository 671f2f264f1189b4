"""Signatures: every message of a run vouched for by the service that produced it.

A run has a secret key per producing service (a :class:`Keyring`). A service signs each
message it publishes with its own key; a receiver checks it with the key of the service
that owns the message's key expression (``proto.keys.owner_of``; the producer named in the
header where a key has no single owner), so that another program on the bus can neither
forge a message of the run nor alter one: the signature covers the whole message as it
travels, the header (every field but ``auth``) and the body exactly as encoded (a frame's
pixels, shape and channels, a fit's landmarks, a status's counts, ...).

Two steps, with the message's digest between them:

1. :func:`digest`: the message's 32-byte BLAKE3 digest over :data:`DOMAIN`, the header map
   encoded with an empty ``auth``, and the body map's bytes. The producer computes it once,
   over the parts it sends (a frame's pixels are hashed where they lie, never copied for
   it); a receiver computes it once over the bytes it received, without encoding the body
   again: the header must be the canonical encoding of its fields (:func:`encode_signed`
   writes nothing else). Hashing a 640 x 360 frame costs about 0.25 ms, four copies of it.
2. :func:`sign_digest` / :func:`verifies`: ``header.auth`` is the first
   :data:`proto.header.AUTH_HEX` hex digits of keyed BLAKE3 (a MAC: 32-byte key) of the
   digest. Only this step knows the key: the signing primitive can change without touching
   how messages are laid out, hashed or sent.
"""

from __future__ import annotations

import hmac
import json
import secrets
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import msgpack

from proto.codec import Buffer, body_parts
from proto.header import AUTH_HEX
from proto.keys import check_name
from proto.message import Message

KEY_BYTES = 32
"""Bytes of a producer's key (BLAKE3's key size)."""
DOMAIN = b"aamtrack message v6\x00"
"""Hashed first, so that a signature of a message is never one of anything else."""
KEYRING_FORMAT = "aamtrack-keyring-1"
_HEAD = b"\x82\xa6header"
"""The payload's first bytes: a map of two entries and the key ``header``."""
_BODY = b"\xa4body"


def digest(head: bytes, *body: Buffer) -> bytes:
    """The 32-byte digest of a message: :data:`DOMAIN`, its header map encoded with an empty
    ``auth`` (``head``), then the body map's bytes, given in as many parts as they lie in."""
    from blake3 import blake3  # imported on first use: a command's --help never needs it

    h = blake3(DOMAIN)
    h.update(head)
    for part in body:
        h.update(part)
    return h.digest()


def sign_digest(key: bytes, message_digest: bytes) -> str:
    """The signature (``header.auth``) of a message of ``message_digest`` under ``key``."""
    from blake3 import blake3

    return blake3(message_digest, key=key).hexdigest(length=AUTH_HEX // 2)


def verifies(key: bytes, message_digest: bytes, auth: str) -> bool:
    """Whether ``auth`` is the signature of ``message_digest`` under ``key``."""
    return hmac.compare_digest(auth, sign_digest(key, message_digest))


def _head(message: Message, auth: str) -> bytes:
    header = message.header.to_dict(message.KIND)
    header["auth"] = auth
    return msgpack.packb(header)


def encode_signed(key: bytes, message: Message) -> bytes:
    """The payload of ``message`` (as :func:`proto.codec.encode` lays it out) with
    ``header.auth`` the signature under ``key``."""
    return b"".join(encode_signed_parts(key, message))


def encode_signed_parts(key: bytes, message: Message) -> list[Buffer]:
    """:func:`encode_signed` in the parts it is made of (:func:`proto.codec.encode_parts`):
    an image's pixels stay where they lie, hashed there once, for a sender to copy once."""
    body = body_parts(message)
    auth = sign_digest(key, digest(_head(message, ""), *body))
    return [b"".join((_HEAD, _head(message, auth), _BODY, body[0])), *body[1:]]


def is_signed(key: bytes, payload: bytes | memoryview, message: Message) -> bool:
    """Whether ``payload``, which decodes to ``message``, carries a signature under ``key``.

    False for an unsigned message, one signed with another key, a signature cut short or a
    header not in canonical form.
    """
    auth = message.header.auth
    if len(auth) != AUTH_HEX:
        return False
    view = memoryview(payload)
    head = _head(message, auth)
    start = len(_HEAD) + len(head)
    if view[:len(_HEAD)] != _HEAD or view[len(_HEAD):start] != head:
        return False
    if view[start:start + len(_BODY)] != _BODY:
        return False
    return verifies(key, digest(_head(message, ""), view[start + len(_BODY):]), auth)


@dataclass(frozen=True)
class Keyring:
    """The keys of a run's producers, and the one this process signs with.

    Attributes
    ----------
    keys : dict of str to bytes
        Service name -> its :data:`KEY_BYTES`-byte key: the keys this process may check
        messages with (its own among them).
    signer : str
        The service this process signs as (empty: it signs nothing).
    """

    keys: Mapping[str, bytes] = field(default_factory=dict)
    signer: str = ""

    def __post_init__(self) -> None:
        for name, key in self.keys.items():
            check_name(name, "keyring service")
            if not isinstance(key, bytes) or len(key) != KEY_BYTES:
                raise ValueError(f"keyring: the key of {name!r} is not {KEY_BYTES} bytes")
        if self.signer and self.signer not in self.keys:
            raise ValueError(f"keyring: no key for its signer {self.signer!r}")

    @classmethod
    def generate(cls, names: Iterable[str]) -> Keyring:
        """Fresh random keys for ``names``."""
        return cls({name: secrets.token_bytes(KEY_BYTES) for name in names})

    def __bool__(self) -> bool:
        return bool(self.keys)

    def for_service(self, name: str, reads: Iterable[str]) -> Keyring:
        """What service ``name`` is given: its own key to sign with, and the keys of the
        services whose messages it reads, to check them with."""
        wanted = {name, *reads}
        return Keyring({n: k for n, k in self.keys.items() if n in wanted}, name)

    def encode(self, message: Message) -> bytes:
        """``message`` encoded and signed with the signer's key."""
        return encode_signed(self.keys[self.signer], message)

    def encode_parts(self, message: Message) -> list[Buffer]:
        """:meth:`encode` in parts, an image's pixels left where they lie
        (:func:`encode_signed_parts`)."""
        return encode_signed_parts(self.keys[self.signer], message)

    def problem(self, payload: bytes | memoryview, message: Message) -> str:
        """Why ``message`` is not vouched for by its producer (``""`` when it is)."""
        key = self.keys.get(message.header.producer)
        if key is None:
            return "not a service of the run"
        if not message.header.auth:
            return "unsigned"
        return "" if is_signed(key, payload, message) else "bad signature"

    def to_bytes(self) -> bytes:
        """The keyring as JSON (what a launcher writes into a service's key pipe, and what
        a keys file holds)."""
        return json.dumps({"format": KEYRING_FORMAT, "signer": self.signer,
                           "keys": {n: k.hex() for n, k in self.keys.items()}}).encode()

    @classmethod
    def from_bytes(cls, data: bytes) -> Keyring:
        """Read :meth:`to_bytes`.

        Raises
        ------
        ValueError
            When ``data`` is not a keyring.
        """
        try:
            obj = json.loads(data)
            if not isinstance(obj, dict) or obj.get("format") != KEYRING_FORMAT:
                raise ValueError(f"not an {KEYRING_FORMAT} keyring")
            keys = {str(n): bytes.fromhex(k) for n, k in dict(obj["keys"]).items()}
            return cls(keys, str(obj.get("signer", "")))
        except (KeyError, TypeError, AttributeError, UnicodeDecodeError) as exc:
            raise ValueError(f"not a keyring: {exc}") from None
