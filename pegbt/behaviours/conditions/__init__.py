"""Leaves that only look: at the blackboard, at a jaw's encoder, at the blocks perception found. They
change nothing; one that keeps watching (`wait_blackboard`, `keep_holding`) runs until what it watches
holds or breaks."""
