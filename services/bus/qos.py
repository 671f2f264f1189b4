"""Quality of service per topic: what may be dropped, what must go first, what must arrive.

- Frames and overlays are large and replaced 30 times a second: droppable,
  at low priority, so that they never hold up a result.
- Fits, poses, expressions and boxes are small and wanted at once:
  interactive priority, sent without batching (``express``).
- End of stream and a service's last status must arrive: blocking
  congestion control, so a publisher waits rather than drops them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from proto.keys import IMAGES, RESULTS


@dataclass(frozen=True)
class QoS:
    """Publisher settings of one topic (names of ``zenoh.CongestionControl`` and
    ``zenoh.Priority`` members)."""

    congestion: str = "DROP"
    priority: str = "DATA"
    express: bool = False

    def publisher_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of ``Session.declare_publisher`` and ``Session.put``."""
        import zenoh

        return {
            "congestion_control": getattr(zenoh.CongestionControl, self.congestion),
            "priority": getattr(zenoh.Priority, self.priority),
            "express": self.express,
        }


DROPPABLE = QoS("DROP", "DATA_LOW", False)
INTERACTIVE = QoS("DROP", "INTERACTIVE_HIGH", True)
MUST_ARRIVE = QoS("BLOCK", "DATA_HIGH", True)
STATUS = QoS("DROP", "DATA", False)

TOPIC_QOS: dict[str, QoS] = {
    **{kind: DROPPABLE for kind in IMAGES},
    **{kind: INTERACTIVE for kind in RESULTS},
    "eos": MUST_ARRIVE,
    "status": STATUS,
}
"""QoS of each message kind's topic; a final status goes out as :data:`MUST_ARRIVE`."""
