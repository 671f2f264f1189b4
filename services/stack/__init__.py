"""The stack as a whole: its description, the launcher, the supervisor and recordings."""
