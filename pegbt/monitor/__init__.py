"""`pegbt monitor` and `pegbt run --monitor`: a browser page showing a tree as it ticks, or a tick log replayed.

`server` serves the page and streams tick-log records over a WebSocket; `live` and `replay` feed it; `world`
turns arms, camera and perception into the 3D scene beside the tree; `causes` names what the page marks.
"""
