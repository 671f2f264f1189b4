"""Bench: what a frame costs on the bus, written once into shared memory or sent as bytes.

1. **Each copy** of a 640 x 360 frame on the way from the decoder to a subscriber's array,
   timed alone in this process (median of many): what the source did before (the array to
   bytes, msgpack packing, joining the signed payload, Zenoh copying the bytes it is given)
   and what it does now (hashing the pixels where they lie, one copy into a shared-memory
   buffer); what each subscriber does (the payload to bytes: zenoh-python's wheel gives no
   buffer view of a payload; decoding it, before with msgpack copying the pixels out of it,
   now reading them where they lie; the signature's hash).
2. **End to end**: a source publishing ``--frames`` frames to ``--subscribers`` subscriber
   processes, real Zenoh sessions on loopback, every message signed and checked as in a run:
   CPU ms a frame of the publisher (its publish call) and of each subscriber (its whole
   process), bytes as before against shared memory.

Run: ``python -m bench frame-transport [--frames 300] [--subscribers 3]``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Callable

import msgpack
import numpy as np

from aamcore.config import REPO_ROOT
from bench import options
from proto import Frame, Header, decode
from proto.auth import Keyring, message_digest
from services.bus.connection import BusOptions
from services.bus.session import Service
from services.bus.shm import POOL_IMAGES, SLACK
from services.source.capture import pixel_buffer
from services.stack.launcher import free_port

SHAPE = (360, 640, 3)
SUBSCRIBER = """
import json, sys, time
from proto.auth import Keyring
from services.bus.connection import BusOptions
from services.bus.session import Service
from services.bus.shm import POOL_IMAGES, SLACK
endpoint, frames, keys = sys.argv[1], int(sys.argv[2]), Keyring.from_bytes(sys.argv[3].encode())
bus = BusOptions("bench", listen=("tcp/127.0.0.1:0",), connect=(endpoint,))
with Service(sys.argv[4], bus, handle_signals=False, keyring=keys) as svc:
    inbox = svc.inbox("frame", capacity=frames)
    svc.ready()
    got = inbox.get(60)
    started, n = time.process_time(), 1
    while n < frames and (got := inbox.get(5)) is not None:
        n += 1
    print(json.dumps({"frames": n, "cpu_s": time.process_time() - started}))
"""


def median_ms(f: Callable[[], object], n: int = 200) -> float:
    f()
    times = []
    for _ in range(n):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return 1000 * float(np.median(times))


def copies() -> list[tuple[str, float]]:
    """Each step a frame goes through, timed alone."""
    import zenoh
    from zenoh import shm

    pixels = bytearray(int(np.prod(SHAPE)))
    image = np.frombuffer(pixels, np.uint8).reshape(SHAPE)
    image[...] = np.random.default_rng(0).integers(0, 255, SHAPE, np.uint8)
    raw = image.tobytes()
    keys = Keyring.generate(["source"])
    signed = keys.for_service("source")
    frame = Frame.from_array(Header.now("bench", 0, "source"), image)
    payload = signed.encode(frame)
    provider = shm.ShmProvider.default_backend(POOL_IMAGES * (len(payload) + SLACK))
    policy = shm.GarbageCollect()

    def into_shm() -> object:
        buffer = provider.alloc(len(raw), policy)
        buffer[:] = pixels
        return zenoh.ZBytes(buffer)

    received = zenoh.ZBytes(payload)
    return [
        ("before, source: array to bytes (ArraySpec.encode + msgpack)",
         median_ms(lambda: msgpack.packb({"data": memoryview(image.reshape(-1))}))),
        ("before, source: join the signed payload", median_ms(lambda: b"".join((b"h", raw)))),
        ("before, source: Zenoh copies the bytes it is given", median_ms(
            lambda: zenoh.ZBytes(payload))),
        ("source: hash the pixels for the signature (before and now)",
         median_ms(lambda: message_digest(b"", pixels))),
        (f"now, source: one copy into a shared-memory buffer (a pool of {POOL_IMAGES})",
         median_ms(into_shm)),
        ("subscriber: payload to bytes (no buffer view in zenoh-python's abi3 wheel)",
         median_ms(received.to_bytes)),
        ("before, subscriber: decode, msgpack copying the pixels out",
         median_ms(lambda: decode(payload))),
        ("now, subscriber: decode, the pixels a view of the payload",
         median_ms(lambda: decode(payload, "frame"))),
        ("subscriber: hash to check the signature",
         median_ms(lambda: message_digest(b"", payload))),
    ]


def end_to_end(frames: int, subscribers: int, shared: bool) -> tuple[float, list[float]]:
    """Publisher CPU ms a frame and each subscriber's, one configuration."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    names = [f"sub{i}" for i in range(subscribers)]
    keys = Keyring.generate(["source", *names])
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    bus = BusOptions("bench", listen=(endpoint,))
    with Service("source", bus, handle_signals=False, announce=False,
                 keyring=keys.for_service("source")) as svc:
        procs = [subprocess.Popen([sys.executable, "-c", SUBSCRIBER, endpoint, str(frames),
                                   keys.for_service(n).to_bytes().decode(), n],
                                  stdout=subprocess.PIPE, text=True, env=env, cwd=REPO_ROOT)
                 for n in names]
        missing = svc.wait_for_alive(names, 60)
        assert not missing, missing
        if shared:
            svc.share_images(POOL_IMAGES)
        image = pixel_buffer(SHAPE)
        image[...] = np.random.default_rng(0).integers(0, 255, SHAPE, np.uint8)
        cpu = 0.0
        for i in range(frames):
            started = time.thread_time()
            svc.publish(Frame.from_array(svc.header(i), image))
            cpu += time.thread_time() - started
            time.sleep(1 / 60)  # the subscribers keep up: no frame is dropped on the way
        outs = [json.loads(p.communicate(timeout=60)[0].strip().splitlines()[-1])
                for p in procs]
    return 1000 * cpu / frames, [1000 * o["cpu_s"] / max(o["frames"] - 1, 1) for o in outs]


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__)
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--subscribers", type=int, default=3)
    args = options.parse(parser, argv)
    print(f"load: {' '.join(f'{x:.2f}' for x in os.getloadavg())}; a 640 x 360 BGR frame, "
          f"{np.prod(SHAPE)} bytes\n\neach step alone (median ms):")
    for what, ms in copies():
        print(f"  {ms:7.3f}  {what}")
    print(f"\nend to end, {args.frames} frames to {args.subscribers} subscriber processes "
          "(CPU ms a frame):")
    for shared in (False, True):
        pub, subs = end_to_end(args.frames, args.subscribers, shared)
        print(f"  {'shared memory' if shared else 'bytes (before)':<15} publisher {pub:.3f}, "
              f"subscribers {', '.join(f'{s:.3f}' for s in subs)}")
    print(f"load: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0

