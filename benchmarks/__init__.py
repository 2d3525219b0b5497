"""acphys benchmarks: engine speed, run time against error, the
service over loopback, and a numerical-stability stress run.

    python3 -m benchmarks                 # everything; rewrites docs/performance.md
    python3 -m benchmarks --quick         # a small run of everything (a few minutes)
    python3 -m benchmarks --only engine,error

See `python3 -m benchmarks --help` and docs/performance.md.
"""
