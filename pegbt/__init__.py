"""pegbt: a behaviour-tree executive for FLS peg transfer on the dVRK, and a sim-to-real tool.

The package is layered; nothing imports anything above it:
executive → behaviours → skills (motion, perception, calibration) → transport → endpoints (sim, dVRK).
"""

__version__ = "0.1.0"
