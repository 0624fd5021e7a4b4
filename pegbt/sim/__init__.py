"""The simulator endpoint: two PSMs behind CRTK topics, a pegboard world and a depth camera that plug in.

`pegbt sim` runs it in real time or in lockstep with a client's `SimClock`; see `endpoint.py`.
"""
