"""Interchange formats: acphys-scene/1 scenes, acphys-trace/1 traces, client dats."""
