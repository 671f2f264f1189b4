"""What every service process shares: its options, its Zenoh session, inboxes and counts."""
