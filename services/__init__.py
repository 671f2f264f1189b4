"""aamtrack services: one process per pipeline stage, plus the command-line tool."""
