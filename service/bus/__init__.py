"""The bus: zenoh sessions and queryables (node.py), each operation's work (dispatch.py), the States
put on P/states (publication.py), the engine thread's queue, the router, and the zenoh configuration
that the service and its clients share (zconfig.py). Above the core; docs/architecture.md, "Layers"."""
