"""Scale-out: `--workers N`, one service face over N engine processes behind a zenoh router
(workers.py), and the answers gathered from all of them (aggregate.py)."""
