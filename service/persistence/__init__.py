"""Durability: the state file and its append-only log.

journal.py (framing, checksums, sync policy) and journal_records.py (what a record holds) are the log the
core writes as it resolves changes, so they sit below the core; state_file.py, state_replay.py,
state_layout.py and lifecycle.py read it all back at start and write the snapshots, above it."""
