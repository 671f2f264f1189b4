"""services.stack.registry: the dataflow is declared once and holds together."""

from __future__ import annotations

from types import SimpleNamespace

from proto.keys import IMAGES, OWNERS, RESULTS, TOPICS
from services.bus.qos import TOPIC_QOS
from services.rerun_logger.service import inputs
from services.stack import drain, recorder
from services.stack.registry import ANSWERS, SERVICES, producers, readers


def test_every_kind_published_is_read_and_every_kind_read_is_published() -> None:
    published = {k for s in SERVICES.values() for k in s.publishes}
    read = {k for s in SERVICES.values() for k in s.reads}
    assert published == read == set(TOPICS)
    for kind in TOPICS:
        assert producers(kind) == [OWNERS[kind]], kind  # the contract's owner, alone
        assert readers(kind), f"nothing reads {kind}"
    asked = {k for s in SERVICES.values() for k in s.asks}
    assert asked == {k for s in SERVICES.values() for k in s.answers}


def test_what_is_derived_from_the_dataflow() -> None:
    assert drain.RESULTS == ANSWERS == ("fit", "pose", "expression", "overlay")
    assert set(recorder.RESULT_KINDS) | set(recorder.IMAGE_KINDS) == {*TOPICS, "status"}
    assert set(TOPIC_QOS) == {*TOPICS, "status"}
    assert {TOPIC_QOS[k].congestion for k in (*IMAGES, *RESULTS)} == {"DROP"}
    logged = {kind for kind, _ in inputs(SimpleNamespace(stream="cam0")).values()}
    assert logged == {*SERVICES["rerun"].reads, "status"}
