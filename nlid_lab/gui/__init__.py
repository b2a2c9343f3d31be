"""Qt views (PySide6 + pyqtgraph, the ``gui`` extra): live campaign view, offline run browser
and offscreen snapshots."""
