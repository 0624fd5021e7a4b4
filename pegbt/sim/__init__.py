"""The simulator: the world the arms act in (pegboard, blocks, ground-truth events) and its depth camera."""
