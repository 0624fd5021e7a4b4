"""Leaves that act: move an arm or its jaw, capture and interpret a point cloud, write the blackboard,
record a transfer for the judge, collect calibration data. Each may take many ticks and change the world."""
