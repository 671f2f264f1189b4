"""Signatures: every message of a run vouched for by the service that produced it, and checked
by any reader with public keys alone.

A run has an Ed25519 key pair per producing service and one for its launcher (a
:class:`Keyring`). A service signs each message it publishes with its own private key; any
reader checks it with the public key of the service that owns the message's key expression
(``proto.keys.owner_of``; the producer named in the header where a key has no single owner),
so that another program on the bus can neither forge a message of the run nor alter one. The
signature covers the whole message as it travels: the header (every field but ``auth``) and
the body exactly as encoded (a frame's pixels, shape and channels, a fit's landmarks, ...).

A message's **digest** is BLAKE3-256 over :data:`DOMAIN`, the header map encoded with an
empty ``auth``, and the body map's bytes (:func:`message_digest`); ``header.auth`` is the
hex of the Ed25519 signature of that digest (:func:`sign`, :func:`verify`). A receiver
recomputes the digest over the bytes it received, without encoding the body again: the
header must be the canonical encoding of its fields (:func:`encode_signed` writes nothing
else). The producer computes the digest once, over the parts it sends
(:func:`encode_signed_parts`: a frame's pixels are hashed where they lie, never copied for
it), and only :func:`sign` and :func:`verify` know the key: the signing primitive can change
without touching how messages are laid out, hashed or sent.

The launcher publishes the run's public keys as a document signed by its own key
(:func:`keys_document`); a reader anchors its trust in the launcher's key by its
:func:`fingerprint` (printed by ``aamtrack run`` and written in its summary) and reads the
document with :func:`read_keys_document`.
"""

from __future__ import annotations

import functools
import hashlib
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
"""Bytes of an Ed25519 private key (its seed) and of a public key."""
SIGNATURE_BYTES = 64
"""Bytes of an Ed25519 signature (``header.auth`` holds their hex)."""
DIGEST_BYTES = 32
DOMAIN = b"aamtrack message v7\x00"
"""Hashed first, so that a digest of a message is never one of anything else."""
KEYS_DOMAIN = b"aamtrack run keys v1\x00"
"""Hashed first in the digest of a run's keys document."""
KEYRING_FORMAT = "aamtrack-keyring-2"
KEYS_DOCUMENT_FORMAT = "aamtrack-run-keys-1"
LAUNCHER = "launcher"
"""The name of the launcher's key: it signs the run's keys document and its own statuses."""
FINGERPRINT_HEX = 32
"""Hex digits of a key's fingerprint (SHA-256 of the public key, cut)."""
_HEAD = b"\x82\xa6header"
"""The payload's first bytes: a map of two entries and the key ``header``."""
_BODY = b"\xa4body"


def _ed25519() -> object:
    # Imported on first use: a command's --help never needs it.
    from cryptography.hazmat.primitives.asymmetric import ed25519

    return ed25519


@functools.lru_cache(maxsize=128)
def _private(secret: bytes) -> object:
    return _ed25519().Ed25519PrivateKey.from_private_bytes(secret)  # type: ignore[attr-defined]


@functools.lru_cache(maxsize=256)
def _public(public: bytes) -> object:
    return _ed25519().Ed25519PublicKey.from_public_bytes(public)  # type: ignore[attr-defined]


def public_key(secret: bytes) -> bytes:
    """The public key of the private key ``secret`` (both :data:`KEY_BYTES` bytes)."""
    from cryptography.hazmat.primitives import serialization as s

    return _private(secret).public_key().public_bytes(  # type: ignore[attr-defined]
        s.Encoding.Raw, s.PublicFormat.Raw)


def fingerprint(public: bytes) -> str:
    """The fingerprint of a public key: the first :data:`FINGERPRINT_HEX` hex digits of its
    SHA-256 (what ``aamtrack run`` prints and readers take with ``--trust``)."""
    return hashlib.sha256(public).hexdigest()[:FINGERPRINT_HEX]


def _blake3(*parts: Buffer) -> bytes:
    from blake3 import blake3  # imported on first use: a command's --help never needs it

    h = blake3()
    for part in parts:
        h.update(part)
    return h.digest()


def message_digest(head: bytes, *body: Buffer) -> bytes:
    """A message's digest: BLAKE3-256 over :data:`DOMAIN`, ``head`` (the header map encoded
    with ``auth`` the empty string) and the body map's bytes as they travel, given in as many
    parts as they lie in."""
    return _blake3(DOMAIN, head, *body)


def sign(secret: bytes, digest: bytes) -> bytes:
    """The Ed25519 signature (:data:`SIGNATURE_BYTES` bytes) of ``digest`` by ``secret``."""
    return _private(secret).sign(digest)  # type: ignore[attr-defined]


def verify(public: bytes, digest: bytes, signature: bytes) -> bool:
    """Whether ``signature`` is the signature of ``digest`` by the key whose public key is
    ``public``."""
    from cryptography.exceptions import InvalidSignature

    try:
        _public(public).verify(signature, digest)  # type: ignore[attr-defined]
    except (InvalidSignature, ValueError):
        return False
    return True


def _head(message: Message, auth: str) -> bytes:
    header = message.header.to_dict(message.KIND)
    header["auth"] = auth
    return msgpack.packb(header)


def encode_signed(secret: bytes, message: Message) -> bytes:
    """The payload of ``message`` (as :func:`proto.codec.encode` lays it out) with
    ``header.auth`` its signature by the private key ``secret``."""
    return b"".join(encode_signed_parts(secret, message))


def encode_signed_parts(secret: bytes, message: Message) -> list[Buffer]:
    """:func:`encode_signed` in the parts it is made of (:func:`proto.codec.encode_parts`):
    an image's pixels stay where they lie, hashed there once, for a sender to copy once."""
    body = body_parts(message)
    auth = sign(secret, message_digest(_head(message, ""), *body)).hex()
    return [b"".join((_HEAD, _head(message, auth), _BODY, body[0])), *body[1:]]


def signature_problem(public: bytes, payload: bytes | memoryview, message: Message) -> str:
    """Why ``payload`` (which decodes to ``message``) is not signed by the key ``public``:
    ``"unsigned"``, ``"bad signature"`` (another key, a changed byte, a header not in
    canonical form), or ``""`` when it is."""
    auth = message.header.auth
    if not auth:
        return "unsigned"
    if len(auth) != AUTH_HEX:
        return "bad signature"
    view = memoryview(payload)
    head = _head(message, auth)
    start = len(_HEAD) + len(head)
    if (view[:len(_HEAD)] != _HEAD or view[len(_HEAD):start] != head
            or view[start:start + len(_BODY)] != _BODY):
        return "bad signature"
    digest = message_digest(_head(message, ""), view[start + len(_BODY):])
    return "" if verify(public, digest, bytes.fromhex(auth)) else "bad signature"


def is_signed(public: bytes, payload: bytes | memoryview, message: Message) -> bool:
    """Whether ``payload``, which decodes to ``message``, is signed by the key ``public``."""
    return signature_problem(public, payload, message) == ""


def _key_bytes(name: str, key: object, what: str) -> bytes:
    check_name(name, "keyring service")
    if not isinstance(key, bytes) or len(key) != KEY_BYTES:
        raise ValueError(f"keyring: the {what} key of {name!r} is not {KEY_BYTES} bytes")
    return key


@dataclass(frozen=True)
class Keyring:
    """The public keys of a run's producers, the private keys this process holds, and the one
    it signs with.

    Attributes
    ----------
    public : dict of str to bytes
        Service name -> its public key: what this process checks messages with (any
        reader may have them: they are no secret).
    secrets : dict of str to bytes
        Service name -> its private key: every one in the launcher, which makes them; a
        service's own only in a service; none in a reader.
    signer : str
        The service this process signs as (empty: it signs nothing).
    """

    public: Mapping[str, bytes] = field(default_factory=dict)
    secrets: Mapping[str, bytes] = field(default_factory=dict, repr=False)
    signer: str = ""

    def __post_init__(self) -> None:
        for name, key in self.public.items():
            _key_bytes(name, key, "public")
        for name, key in self.secrets.items():
            _key_bytes(name, key, "private")
            if self.public.get(name) != public_key(key):
                raise ValueError(f"keyring: the private key of {name!r} is not its public "
                                 "key's")
        if self.signer and self.signer not in self.secrets:
            raise ValueError(f"keyring: no private key for its signer {self.signer!r}")

    @classmethod
    def from_secrets(cls, secret_keys: Mapping[str, bytes], signer: str = "") -> Keyring:
        """The keyring of these private keys (their public keys derived)."""
        for name, key in secret_keys.items():
            _key_bytes(name, key, "private")
        return cls({n: public_key(k) for n, k in secret_keys.items()}, dict(secret_keys),
                   signer)

    @classmethod
    def generate(cls, names: Iterable[str]) -> Keyring:
        """Fresh random key pairs for ``names``."""
        return cls.from_secrets({name: secrets.token_bytes(KEY_BYTES) for name in names})

    def __bool__(self) -> bool:
        return bool(self.public)

    def for_service(self, name: str) -> Keyring:
        """What service ``name`` is given: its own private key to sign with, and every
        public key of the run, to check messages with."""
        return Keyring(self.public, {name: self.secrets[name]}, name)

    def public_only(self) -> Keyring:
        """The public keys alone: what a reader needs (it signs nothing)."""
        return Keyring(self.public)

    def encode(self, message: Message) -> bytes:
        """``message`` encoded and signed with the signer's private key."""
        return encode_signed(self.secrets[self.signer], message)

    def encode_parts(self, message: Message) -> list[Buffer]:
        """:meth:`encode` in parts, an image's pixels left where they lie
        (:func:`encode_signed_parts`)."""
        return encode_signed_parts(self.secrets[self.signer], message)

    def problem(self, payload: bytes | memoryview, message: Message) -> str:
        """Why ``message`` is not vouched for by its producer (``""`` when it is)."""
        key = self.public.get(message.header.producer)
        if key is None:
            return "not a service of the run"
        return signature_problem(key, payload, message)

    @property
    def fingerprint(self) -> str:
        """The fingerprint of the launcher's public key (empty without one)."""
        key = self.public.get(LAUNCHER)
        return fingerprint(key) if key else ""

    def to_bytes(self) -> bytes:
        """The keyring as JSON (what a launcher hands a service, and what a keys file
        holds)."""
        return json.dumps({"format": KEYRING_FORMAT, "signer": self.signer,
                           "public": {n: k.hex() for n, k in self.public.items()},
                           "secret": {n: k.hex() for n, k in self.secrets.items()}}).encode()

    @classmethod
    def from_bytes(cls, data: bytes) -> Keyring:
        """Read :meth:`to_bytes`.

        Raises
        ------
        ValueError
            When ``data`` is not a keyring (or a key in it has the wrong length).
        """
        try:
            obj = json.loads(data)
            if not isinstance(obj, dict) or obj.get("format") != KEYRING_FORMAT:
                raise ValueError(f"not an {KEYRING_FORMAT} keyring")
            public = {str(n): bytes.fromhex(k) for n, k in dict(obj["public"]).items()}
            private = {str(n): bytes.fromhex(k) for n, k in dict(obj["secret"]).items()}
            return cls({**{n: public_key(_key_bytes(n, k, "private"))
                           for n, k in private.items()}, **public}, private,
                       str(obj.get("signer", "")))
        except (KeyError, TypeError, AttributeError, UnicodeDecodeError) as exc:
            raise ValueError(f"not a keyring: {exc}") from None


def keys_document(keyring: Keyring, stream: str, run_id: str) -> bytes:
    """The run's public keys, signed by the launcher's private key: what the launcher
    answers on ``aamtrack/<stream>/keys`` and what a recording starts with."""
    body = {"format": KEYS_DOCUMENT_FORMAT, "stream_id": stream, "run_id": run_id,
            "keys": dict(sorted(keyring.public.items()))}
    packed = msgpack.packb(body, use_bin_type=True)
    signature = sign(keyring.secrets[LAUNCHER], _blake3(KEYS_DOMAIN, packed))
    return msgpack.packb({"document": packed, "signature": signature}, use_bin_type=True)


@dataclass(frozen=True)
class RunKeys:
    """A run's public keys as its launcher vouched for them (:func:`read_keys_document`)."""

    keyring: Keyring
    stream: str
    run_id: str
    document: bytes = field(default=b"", repr=False)
    """The launcher's signed document, as received (a recording starts with it)."""

    @property
    def fingerprint(self) -> str:
        return self.keyring.fingerprint


def read_keys_document(data: bytes, trust: str = "") -> RunKeys:
    """The public keys of a run from its launcher's document, checked against the launcher's
    own key (and that key against the fingerprint ``trust``, when given).

    Raises
    ------
    ValueError
        When ``data`` is no such document, its signature is not its launcher's, or its
        launcher is not the one ``trust`` names.
    """
    try:
        outer = msgpack.unpackb(data, raw=False)
        packed, signature = outer["document"], outer["signature"]
        obj = msgpack.unpackb(packed, raw=False)
        if obj.get("format") != KEYS_DOCUMENT_FORMAT:
            raise ValueError(f"not an {KEYS_DOCUMENT_FORMAT} document")
        keyring = Keyring({str(n): k for n, k in dict(obj["keys"]).items()})
        stream, run_id = str(obj["stream_id"]), str(obj["run_id"])
    except (msgpack.UnpackException, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise ValueError(f"not a run's keys: {exc}") from None
    launcher = keyring.public.get(LAUNCHER)
    if launcher is None or not isinstance(signature, bytes) or not verify(
            launcher, _blake3(KEYS_DOMAIN, packed), signature):
        raise ValueError("a run's keys not signed by its launcher")
    if trust and (len(trust) < 16 or not fingerprint(launcher).startswith(trust.lower())):
        raise ValueError(f"the run's launcher key {fingerprint(launcher)} is not the "
                         f"trusted {trust}")
    return RunKeys(keyring, stream, run_id, bytes(data))
