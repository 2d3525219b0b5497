"""Test-only helpers, one module each: the service harness (service_harness), TLS cluster files
(cluster_files), indoor scene dicts (indoor_scenes), the replay tolerances (replay_tolerances), the dat
writer and records, scene comparison and checks, shared data paths, and the rest; never imported by the
project. The synthetic terrain and player the scenario tests share with the benchmarks are
benchmarks/scenes.py's."""
