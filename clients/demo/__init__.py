"""`acphys demo`: the demo world (world.py, which writes demo.json), the walk over it (walk.py), and the
picture of the walk (picture.py, map.py, labels.py, label_layout.py)."""
