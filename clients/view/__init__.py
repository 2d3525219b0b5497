"""`acphys view`: the live map, a page served over HTTP (server.py) that draws terrain, objects, the
movers the service publishes, and paths."""
